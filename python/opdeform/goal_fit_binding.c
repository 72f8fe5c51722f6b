// opdeform._core, goal part: GoalFit, the goal frames of a graph's particles fitted to an animated mesh
// (csrc/mesh/goal_fit.c). A fit is O(particles) and runs with the GIL held, so the type needs no busy guard.
#include "goal_fit_binding.h"

#include "graph_binding.h"

#include "opdeform/mesh.h"

#include <string.h>

typedef struct
{
	PyObject_HEAD od_GoalFit* fit;
	Py_ssize_t particles;
} GoalFitObject;

// GoalFit(graph, vertices, neighbors)
static PyObject* GoalFit_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "graph", "vertices", "neighbors", NULL };
	PyObject *graphObj, *vertices;
	int neighbors;
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOi", keywords, &graphObj, &vertices, &neighbors))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	const od_Graph* graph = Graph_FromObject(module, graphObj);
	Py_ssize_t nv = graph ? ItemCount(vertices, "vertices", 24) : -1;
	Py_buffer vv;
	if (nv < 0 || GetArray(vertices, "vertices", 'd', 3 * nv, 0, &vv) < 0)
	{
		return NULL;
	}
	od_GoalFitDef def = od_DefaultGoalFitDef();
	def.vertexCount = (int)nv;
	def.vertices = vv.buf;
	def.neighbors = neighbors;
	od_GoalFit* fit = NULL;
	PyThreadState* ts = Binding_Release(); // 0.07 s for 20,000 particles; Ctrl-C polled
	od_Status status = od_GoalFit_Create(graph, &def, &fit);
	Binding_Reacquire(ts);
	PyBuffer_Release(&vv);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	GoalFitObject* self = (GoalFitObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_GoalFit_Destroy(fit);
		return NULL;
	}
	self->fit = fit;
	self->particles = od_Graph_GetParticleCount(graph);
	return (PyObject*)self;
}

static void GoalFit_dealloc(PyObject* obj)
{
	od_GoalFit_Destroy(((GoalFitObject*)obj)->fit);
	Binding_Free(obj);
}

// fit(animated, positions_out, rotations_out, shift=None): animated float64, or float32 with a shift (3, float64)
static PyObject* GoalFit_fit(PyObject* obj, PyObject* args)
{
	GoalFitObject* self = (GoalFitObject*)obj;
	PyObject *animated, *positions, *rotations, *shift = Py_None;
	if (!PyArg_ParseTuple(args, "OOO|O", &animated, &positions, &rotations, &shift))
	{
		return NULL;
	}
	char type = shift == Py_None ? 'd' : 'f';
	Py_buffer views[4] = { { 0 } };
	if (GetArray(animated, "animated", type, 3 * (Py_ssize_t)od_GoalFit_GetVertexCount(self->fit), 0, &views[0]) < 0 ||
		GetArray(positions, "positions", 'd', 3 * self->particles, 1, &views[1]) < 0 ||
		GetArray(rotations, "rotations", 'd', 9 * self->particles, 1, &views[2]) < 0 ||
		GetOptionalArray(shift, "shift", 'd', 3, &views[3]) < 0)
	{
		ReleaseArrays(views, 4);
		return NULL;
	}
	od_Status status = type == 'd' ? od_GoalFit_Compute(self->fit, views[0].buf, views[1].buf, views[2].buf)
								   : od_GoalFit_ComputeShifted(self->fit, views[0].buf, views[3].buf, views[1].buf,
															   views[2].buf);
	ReleaseArrays(views, 4);
	return Binding_Done(obj, status);
}

// follow(animated, shift, kept, kept_shift, valid, positions_out, rotations_out) -> bool: od_GoalFit_Follow; animated
// and kept float32 (V*3), shift and kept_shift float64 (3); True when fitted (outputs and kept written).
static PyObject* GoalFit_follow(PyObject* obj, PyObject* args)
{
	GoalFitObject* self = (GoalFitObject*)obj;
	PyObject* objs[6];
	int valid;
	if (!PyArg_ParseTuple(args, "OOOOpOO", &objs[0], &objs[1], &objs[2], &objs[3], &valid, &objs[4], &objs[5]))
	{
		return NULL;
	}
	Py_ssize_t nv = 3 * (Py_ssize_t)od_GoalFit_GetVertexCount(self->fit);
	const ArraySpec inSpecs[2] = { { "animated", 'f', nv, 0 }, { "shift", 'd', 3, 0 } };
	const ArraySpec outSpecs[4] = { { "kept", 'f', nv, 0 },
									{ "kept_shift", 'd', 3, 0 },
									{ "positions", 'd', 3 * self->particles, 0 },
									{ "rotations", 'd', 9 * self->particles, 0 } };
	Py_buffer views[2], outViews[4];
	if (GetInOutArrays(objs, inSpecs, 2, views, outSpecs, 4, outViews) < 0)
	{
		return NULL;
	}
	const char *in = views[0].buf, *keep = outViews[0].buf;
	if (in < keep + outViews[0].len && keep < in + views[0].len)
	{
		ReleaseArrays(views, 2);
		ReleaseArrays(outViews, 4);
		PyErr_SetString(PyExc_ValueError, "kept must not share memory with animated (it keeps a copy of it)");
		return NULL;
	}
	od_KeptInput kept = { outViews[0].buf, outViews[1].buf, valid != 0 };
	bool fitted = false;
	od_Status status = od_GoalFit_Follow(self->fit, views[0].buf, views[1].buf, &kept, &fitted, outViews[2].buf,
										 outViews[3].buf);
	ReleaseArrays(views, 2);
	ReleaseArrays(outViews, 4);
	return status != OD_OK ? RaiseStatus(Binding_Module(obj), status) : PyBool_FromLong(fitted);
}

// read(name, out): "indices" (int32 n*k) or "weights" (float64 n*k).
static PyObject* GoalFit_read(PyObject* obj, PyObject* args)
{
	GoalFitObject* self = (GoalFitObject*)obj;
	const char* name;
	PyObject* out;
	if (!PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	Py_ssize_t count = self->particles * od_GoalFit_GetNeighborCount(self->fit);
	int indices = strcmp(name, "indices") == 0;
	if (!indices && strcmp(name, "weights") != 0)
	{
		PyErr_Format(PyExc_ValueError, "unknown GoalFit array '%s'", name);
		return NULL;
	}
	const void* data = indices ? (const void*)od_GoalFit_GetIndices(self->fit) : od_GoalFit_GetWeights(self->fit);
	return CopyOut(out, "out", data, count, indices ? 'i' : 'd') < 0 ? NULL : PyLong_FromSsize_t(count);
}

// The counts a GoalFit reports; a getter's closure points at one of them.
typedef int (*GoalFitCount)(const od_GoalFit* fit);
static const GoalFitCount GoalFitCounts[2] = { od_GoalFit_GetVertexCount, od_GoalFit_GetNeighborCount };

static PyObject* GoalFit_get_count(PyObject* obj, void* closure)
{
	return PyLong_FromLong((*(const GoalFitCount*)closure)(((GoalFitObject*)obj)->fit));
}

static PyGetSetDef GoalFit_getset[] = {
	{ "n_vertices", GoalFit_get_count, NULL, "rest vertices", (void*)&GoalFitCounts[0] },
	{ "neighbors", GoalFit_get_count, NULL, "vertices per particle", (void*)&GoalFitCounts[1] },
	{ NULL, NULL, NULL, NULL, NULL },
};

static PyMethodDef GoalFit_methods[] = {
	{ "fit", GoalFit_fit, METH_VARARGS,
	  "fit(animated, positions_out, rotations_out, shift=None): animated float64, or float32 plus a float64 shift" },
	{ "follow", GoalFit_follow, METH_VARARGS,
	  "follow(animated, shift, kept, kept_shift, valid, positions_out, rotations_out) -> bool: fitted unless the "
	  "input is the kept one" },
	{ "read", GoalFit_read, METH_VARARGS, "read(name, out): copy 'indices' or 'weights'" },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot GoalFit_slots[] = {
	{ Py_tp_doc, "Goal frames of a graph's particles fitted to an animated mesh (C core)." },
	{ Py_tp_new, GoalFit_new },
	{ Py_tp_dealloc, GoalFit_dealloc },
	{ Py_tp_getset, GoalFit_getset },
	{ Py_tp_methods, GoalFit_methods },
	{ 0, NULL },
};

PyType_Spec GoalFit_Spec = {
	.name = "opdeform._core.GoalFit",
	.basicsize = sizeof(GoalFitObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = GoalFit_slots,
};
