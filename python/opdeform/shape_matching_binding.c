// opdeform._core.ShapeMatching: the thin binding of the shape-matching baseline
// (csrc/include/opdeform/shape_matching.h).
//
// Arguments arrive checked and converted by opdeform/shape_matching.py. The object speaks the same
// protocol as opdeform._core.Simulation where the two overlap (read(name, out), set_state, params,
// set_params, counters, constraint_count, set_floor, clear_floor, step), so the Python layer shares the
// Simulation's accessors. The GIL is released around steps; a busy flag refuses other calls meanwhile.
#include "binding.h"

#include "opdeform/shape_matching.h"

#include <string.h>

typedef struct
{
	PyObject_HEAD od_ShapeMatching* sm;
	PyObject* graph; // keeps the od_Graph alive
	Py_ssize_t n;    // particles
	int busy;
} SmObject;

static PyObject* SmDone(PyObject* obj, od_Status status)
{
	if (status != OD_OK)
	{
		return RaiseStatus(PyType_GetModule(Py_TYPE(obj)), status);
	}
	Py_RETURN_NONE;
}

static od_ShapeMatching* SmEnter(PyObject* obj)
{
	SmObject* self = (SmObject*)obj;
	if (self->busy)
	{
		PyErr_SetString(PyExc_RuntimeError, "the shape-matching solver is being stepped by another thread");
		return NULL;
	}
	return self->sm;
}

// Positional (stiffness, density, dt, iterations, gravity, damping, skin_neighbors) after `prefix`.
#define SM_DEF_FORMAT "dddi(ddd)di"
#define SM_DEF_ARGS(d)                                                                                                \
	&(d).stiffness, &(d).density, &(d).dt, &(d).iterations, &(d).gravity[0], &(d).gravity[1], &(d).gravity[2],       \
		&(d).damping, &(d).skinNeighbors

// ShapeMatching(graph, stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sm_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	PyObject* module = PyType_GetModule(type);
	PyObject* graphObj;
	od_ShapeMatchingDef def = od_DefaultShapeMatchingDef();
	if (kwargs && PyDict_Size(kwargs) > 0)
	{
		PyErr_SetString(PyExc_TypeError, "ShapeMatching takes positional arguments only");
		return NULL;
	}
	if (!PyArg_ParseTuple(args, "O" SM_DEF_FORMAT, &graphObj, SM_DEF_ARGS(def)))
	{
		return NULL;
	}
	const od_Graph* graph = Binding_Graph(module, graphObj);
	if (!graph)
	{
		return NULL;
	}
	od_ShapeMatching* sm = NULL;
	od_Status status = od_ShapeMatching_Create(graph, &def, &sm);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	SmObject* self = (SmObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_ShapeMatching_Destroy(sm);
		return NULL;
	}
	self->sm = sm;
	Py_INCREF(graphObj);
	self->graph = graphObj;
	self->n = od_Graph_GetParticleCount(graph);
	return (PyObject*)self;
}

static void Sm_dealloc(PyObject* obj)
{
	SmObject* self = (SmObject*)obj;
	PyTypeObject* type = Py_TYPE(obj);
	od_ShapeMatching_Destroy(self->sm);
	Py_XDECREF(self->graph);
	freefunc tp_free = (freefunc)PyType_GetSlot(type, Py_tp_free);
	tp_free(obj);
	Py_DECREF(type);
}

// add_position_constraint((x,y,z), target or None) -> id
static PyObject* Sm_add_position_constraint(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	double p[3], t[3];
	PyObject* target;
	if (!sm || !PyArg_ParseTuple(args, "(ddd)O", &p[0], &p[1], &p[2], &target))
	{
		return NULL;
	}
	if (target != Py_None && !PyArg_ParseTuple(target, "ddd", &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_ShapeMatching_AddPositionConstraint(sm, p, target == Py_None ? NULL : t, &id);
	return status == OD_OK ? PyLong_FromLong(id) : SmDone(obj, status);
}

static PyObject* Sm_set_constraint_target(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	int id;
	double t[3];
	if (!sm || !PyArg_ParseTuple(args, "i(ddd)", &id, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	return SmDone(obj, od_ShapeMatching_SetConstraintTarget(sm, id, t));
}

static PyObject* Sm_constraint_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	return PyLong_FromLong(od_ShapeMatching_GetConstraintCount(((SmObject*)obj)->sm));
}

static PyObject* Sm_set_floor(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	double height, friction;
	if (!sm || !PyArg_ParseTuple(args, "dd", &height, &friction))
	{
		return NULL;
	}
	return SmDone(obj, od_ShapeMatching_SetFloor(sm, height, friction));
}

static PyObject* Sm_clear_floor(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatching* sm = SmEnter(obj);
	if (!sm)
	{
		return NULL;
	}
	od_ShapeMatching_ClearFloor(sm);
	Py_RETURN_NONE;
}

static PyObject* Sm_step(PyObject* obj, PyObject* args)
{
	SmObject* self = (SmObject*)obj;
	int steps;
	if (!SmEnter(obj) || !PyArg_ParseTuple(args, "i", &steps))
	{
		return NULL;
	}
	self->busy = 1;
	PyThreadState* ts = PyEval_SaveThread();
	od_Status status = od_ShapeMatching_Step(self->sm, steps);
	PyEval_RestoreThread(ts);
	self->busy = 0;
	return SmDone(obj, status);
}

// set_state(positions, rotations, velocities or None, angular_velocities or None)
static PyObject* Sm_set_state(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	PyObject* arrays[4] = { NULL, NULL, Py_None, Py_None };
	if (!sm || !PyArg_ParseTuple(args, "OO|OO", &arrays[0], &arrays[1], &arrays[2], &arrays[3]))
	{
		return NULL;
	}
	static const char* const names[4] = { "positions", "rotations", "velocities", "angular_velocities" };
	static const int widths[4] = { 3, 9, 3, 3 };
	Py_ssize_t n = ((SmObject*)obj)->n;
	Py_buffer views[4];
	memset(views, 0, sizeof views);
	int ok = 1;
	for (int a = 0; a < 4 && ok; ++a)
	{
		ok = (a < 2 ? GetArray(arrays[a], names[a], 'd', widths[a] * n, 0, &views[a])
					: GetOptionalArray(arrays[a], names[a], 'd', widths[a] * n, &views[a])) == 0;
	}
	od_Status status = OD_OK;
	if (ok)
	{
		status = od_ShapeMatching_SetState(sm, views[0].buf, views[1].buf, views[2].obj ? views[2].buf : NULL,
										   views[3].obj ? views[3].buf : NULL);
	}
	for (int a = 0; a < 4; ++a)
	{
		ReleaseArray(&views[a]);
	}
	return ok ? SmDone(obj, status) : NULL;
}

// read(name, out): "positions", "rotations", "velocities" or "angular_velocities" into a float64 buffer.
static PyObject* Sm_read(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	const char* name;
	PyObject* out;
	if (!sm || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	static const char* const names[4] = { "positions", "rotations", "velocities", "angular_velocities" };
	const double* fields[4] = { od_ShapeMatching_GetPositions(sm), od_ShapeMatching_GetRotations(sm),
								od_ShapeMatching_GetVelocities(sm), od_ShapeMatching_GetAngularVelocities(sm) };
	Py_ssize_t n = ((SmObject*)obj)->n;
	for (int f = 0; f < 4; ++f)
	{
		if (strcmp(name, names[f]) == 0)
		{
			Py_ssize_t count = (f == 1 ? 9 : 3) * n;
			return CopyOut(out, "out", fields[f], count, 'd') < 0 ? NULL : PyLong_FromSsize_t(count);
		}
	}
	PyErr_Format(PyExc_ValueError, "unknown state array '%s'", name);
	return NULL;
}

static PyObject* Sm_params(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatchingDef d = od_ShapeMatching_GetDef(((SmObject*)obj)->sm);
	return Py_BuildValue("{sdsdsdsis(ddd)sdsi}", "stiffness", d.stiffness, "density", d.density, "dt", d.dt,
						 "iterations", d.iterations, "gravity", d.gravity[0], d.gravity[1], d.gravity[2], "damping",
						 d.damping, "skin_neighbors", d.skinNeighbors);
}

// set_params(stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sm_set_params(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = SmEnter(obj);
	od_ShapeMatchingDef d;
	if (!sm || !PyArg_ParseTuple(args, SM_DEF_FORMAT, SM_DEF_ARGS(d)))
	{
		return NULL;
	}
	return SmDone(obj, od_ShapeMatching_SetDef(sm, &d));
}

static PyObject* Sm_counters(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatchingCounters c = od_ShapeMatching_GetCounters(((SmObject*)obj)->sm);
	return Py_BuildValue("{sLsLsL}", "steps", c.steps, "group_solves", c.groupSolves, "polar_fallbacks",
						 c.polarFallbacks);
}

static PyMethodDef Sm_methods[] = {
	{ "add_position_constraint", Sm_add_position_constraint, METH_VARARGS, NULL },
	{ "set_constraint_target", Sm_set_constraint_target, METH_VARARGS, NULL },
	{ "constraint_count", Sm_constraint_count, METH_NOARGS, NULL },
	{ "set_floor", Sm_set_floor, METH_VARARGS, NULL },
	{ "clear_floor", Sm_clear_floor, METH_NOARGS, NULL },
	{ "step", Sm_step, METH_VARARGS, NULL },
	{ "set_state", Sm_set_state, METH_VARARGS, NULL },
	{ "read", Sm_read, METH_VARARGS, NULL },
	{ "params", Sm_params, METH_NOARGS, NULL },
	{ "set_params", Sm_set_params, METH_VARARGS, NULL },
	{ "counters", Sm_counters, METH_NOARGS, NULL },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Sm_slots[] = {
	{ Py_tp_doc, "Gauss-Seidel shape matching with oriented particles (Müller and Chentanez 2011), C core." },
	{ Py_tp_new, Sm_new },
	{ Py_tp_dealloc, Sm_dealloc },
	{ Py_tp_methods, Sm_methods },
	{ 0, NULL },
};

static PyType_Spec Sm_spec = {
	.name = "opdeform._core.ShapeMatching",
	.basicsize = sizeof(SmObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Sm_slots,
};

int Binding_AddShapeMatching(PyObject* module)
{
	PyObject* type = PyType_FromModuleAndSpec(module, &Sm_spec, NULL);
	if (!type)
	{
		return -1;
	}
	int rc = PyModule_AddObjectRef(module, "ShapeMatching", type);
	Py_DECREF(type);
	return rc;
}
