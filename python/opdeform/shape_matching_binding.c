// opdeform._core.ShapeMatching: the thin binding of the shape-matching baseline
// (csrc/include/opdeform/shape_matching.h).
//
// Arguments arrive checked and converted by opdeform/shape_matching.py. The object speaks the same
// protocol as opdeform._core.Simulation where the two overlap (read(name, out), set_state, params,
// set_params, counters, constraint_count, set_floor, clear_floor, step), so the Python layer shares the
// Simulation's accessors. The GIL is released around steps; the busy guard refuses every call meanwhile.
#include "graph_binding.h"
#include "shape_matching_binding.h"

#include "opdeform/shape_matching.h"

typedef struct
{
	GuardedObject head;
	od_ShapeMatching* sm;
	PyObject* graph; // keeps the od_Graph alive
	Py_ssize_t n;    // particles
} SmObject;

// The od_ShapeMatching of obj, or NULL with RuntimeError while a step on another thread runs.
static od_ShapeMatching* Sm_Enter(PyObject* obj)
{
	return Binding_Enter(obj) < 0 ? NULL : ((SmObject*)obj)->sm;
}

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
	if (!PyArg_ParseTuple(args, "O" BINDING_DEF_FORMAT, &graphObj, BINDING_DEF_ARGS(def)))
	{
		return NULL;
	}
	const od_Graph* graph = Graph_FromObject(module, graphObj);
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
	self->graph = Py_NewRef(graphObj);
	self->n = od_Graph_GetParticleCount(graph);
	return (PyObject*)self;
}

static void Sm_dealloc(PyObject* obj)
{
	SmObject* self = (SmObject*)obj;
	od_ShapeMatching_Destroy(self->sm);
	Py_XDECREF(self->graph);
	Binding_Free(obj);
}

// add_position_constraint((x,y,z), target or None) -> id
static PyObject* Sm_add_position_constraint(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	double p[3], t[3];
	PyObject* target;
	int given;
	if (!sm || !PyArg_ParseTuple(args, "(ddd)O", &p[0], &p[1], &p[2], &target) ||
		GetOptionalPoint(target, t, &given) < 0)
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_ShapeMatching_AddPositionConstraint(sm, p, given ? t : NULL, &id);
	return Binding_Id(obj, status, id);
}

static PyObject* Sm_set_constraint_target(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	int id;
	double t[3];
	if (!sm || !PyArg_ParseTuple(args, "i(ddd)", &id, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	return Binding_Done(obj, od_ShapeMatching_SetConstraintTarget(sm, id, t));
}

static PyObject* Sm_constraint_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatching* sm = Sm_Enter(obj);
	return sm ? PyLong_FromLong(od_ShapeMatching_GetConstraintCount(sm)) : NULL;
}

static PyObject* Sm_set_floor(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	double height, friction;
	if (!sm || !PyArg_ParseTuple(args, "dd", &height, &friction))
	{
		return NULL;
	}
	return Binding_Done(obj, od_ShapeMatching_SetFloor(sm, height, friction));
}

static PyObject* Sm_clear_floor(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatching* sm = Sm_Enter(obj);
	if (!sm)
	{
		return NULL;
	}
	od_ShapeMatching_ClearFloor(sm);
	Py_RETURN_NONE;
}

static PyObject* Sm_step(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	int steps;
	if (!sm || !PyArg_ParseTuple(args, "i", &steps))
	{
		return NULL;
	}
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = od_ShapeMatching_Step(sm, steps);
	Binding_End(obj, ts);
	return Binding_Done(obj, status);
}

// set_state(positions, rotations, velocities=None, angular_velocities=None)
static PyObject* Sm_set_state(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	Py_buffer v[4];
	if (!sm || GetStateArrays(args, ((SmObject*)obj)->n, v) < 0)
	{
		return NULL;
	}
	od_Status status = od_ShapeMatching_SetState(sm, v[0].buf, v[1].buf, ArrayData(&v[2]), ArrayData(&v[3]));
	ReleaseArrays(v, 4);
	return Binding_Done(obj, status);
}

// read(name, out) -> count: "positions", "rotations", "velocities" or "angular_velocities".
static PyObject* Sm_read(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	const char* name;
	PyObject* out;
	if (!sm || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	const double* fields[4] = { od_ShapeMatching_GetPositions(sm), od_ShapeMatching_GetRotations(sm),
								od_ShapeMatching_GetVelocities(sm), od_ShapeMatching_GetAngularVelocities(sm) };
	int index = StateArrayIndex(name);
	if (index < 0)
	{
		PyErr_Format(PyExc_ValueError, "unknown state array '%s'", name);
		return NULL;
	}
	Py_ssize_t count = StateArrayCount(index, ((SmObject*)obj)->n);
	return CopyOut(out, "out", fields[index], count, 'd') < 0 ? NULL : PyLong_FromSsize_t(count);
}

static PyObject* Sm_params(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatching* sm = Sm_Enter(obj);
	return sm ? BINDING_DEF_DICT(od_ShapeMatching_GetDef(sm)) : NULL;
}

// set_params(stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sm_set_params(PyObject* obj, PyObject* args)
{
	od_ShapeMatching* sm = Sm_Enter(obj);
	od_ShapeMatchingDef d;
	if (!sm || !PyArg_ParseTuple(args, BINDING_DEF_FORMAT, BINDING_DEF_ARGS(d)))
	{
		return NULL;
	}
	return Binding_Done(obj, od_ShapeMatching_SetDef(sm, &d));
}

static PyObject* Sm_counters(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_ShapeMatching* sm = Sm_Enter(obj);
	if (!sm)
	{
		return NULL;
	}
	od_ShapeMatchingCounters c = od_ShapeMatching_GetCounters(sm);
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

PyType_Spec ShapeMatching_Spec = {
	.name = "opdeform._core.ShapeMatching",
	.basicsize = sizeof(SmObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Sm_slots,
};
