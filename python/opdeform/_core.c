// opdeform._core: the thin CPython binding of the C core.
//
// Built against the limited API 3.11 (one abi3 binary for every CPython >= 3.11, Blender's included).
// Arrays cross through the buffer protocol only (no numpy C API): callers hand in C-contiguous float64
// or int32 buffers of the right size, and getters fill caller-provided writable buffers. The Python layer
// (opdeform/__init__.py) does shape conversion; this layer checks sizes, maps status codes to exceptions
// and releases the GIL around the heavy calls. Types are heap types kept in module state.
#include "binding.h"

#include <string.h>

static ModuleState* GetState(PyObject* module)
{
	return (ModuleState*)PyModule_GetState(module);
}

const od_Graph* Binding_Graph(PyObject* module, PyObject* obj)
{
	if (!PyObject_TypeCheck(obj, GetState(module)->graphType))
	{
		PyErr_SetString(PyExc_TypeError, "expected an opdeform._core.Graph");
		return NULL;
	}
	return ((GraphObject*)obj)->graph;
}

SimObject* Binding_Sim(PyObject* module, PyObject* obj)
{
	if (!PyObject_TypeCheck(obj, GetState(module)->simType))
	{
		PyErr_SetString(PyExc_TypeError, "expected an opdeform._core.Simulation");
		return NULL;
	}
	return (SimObject*)obj;
}

PyObject* RaiseStatus(PyObject* module, od_Status status)
{
	PyObject* type;
	switch (status)
	{
		case OD_ERROR_ARGUMENT:
		case OD_ERROR_SINGULAR:
			type = PyExc_ValueError;
			break;
		case OD_ERROR_NOT_FOUND:
			type = PyExc_IndexError;
			break;
		case OD_ERROR_MEMORY:
			type = PyExc_MemoryError;
			break;
		case OD_ERROR_BUSY:
			type = PyExc_RuntimeError;
			break;
		default:
			type = GetState(module)->solverError;
			break;
	}
	PyErr_SetString(type, od_GetErrorMessage());
	return NULL;
}

// ---------------------------------------------------------------------------------------------------------
// Buffers

static const char* FormatName(char fmt)
{
	return fmt == 'd' ? "float64" : fmt == 'f' ? "float32" : "int32";
}

// Gets a C-contiguous buffer of `count` items of the format `fmt` ("d" or "i"); NULL/None when allowed.
int GetArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, int writable, Py_buffer* view)
{
	memset(view, 0, sizeof *view);
	int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
	if (PyObject_GetBuffer(obj, view, flags) < 0)
	{
		PyErr_Clear();
		PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous %s buffer", name, FormatName(fmt));
		return -1;
	}
	const char* f = view->format ? view->format : "B";
	if (*f == '<' || *f == '=' || *f == '@')
	{
		++f;
	}
	Py_ssize_t itemsize = fmt == 'd' ? 8 : 4; // 'i' int32, 'f' float32
	if (f[0] != fmt || f[1] != '\0' || view->itemsize != itemsize || view->len != count * itemsize)
	{
		PyErr_Format(PyExc_ValueError, "%s must hold %zd %s values (got %zd bytes of format '%s')", name, count,
					 FormatName(fmt), view->len, view->format ? view->format : "B");
		PyBuffer_Release(view);
		return -1;
	}
	return 0;
}

// The number of items of `itemsize` bytes in a buffer (for sizing n from centers and m from edges).
Py_ssize_t ItemCount(PyObject* obj, const char* name, Py_ssize_t itemsize)
{
	Py_buffer view;
	if (PyObject_GetBuffer(obj, &view, PyBUF_C_CONTIGUOUS) < 0)
	{
		PyErr_Clear();
		PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous buffer", name);
		return -1;
	}
	Py_ssize_t count = view.len / itemsize;
	PyBuffer_Release(&view);
	return count;
}

int GetOptionalArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, Py_buffer* view)
{
	memset(view, 0, sizeof *view);
	return obj == Py_None ? 0 : GetArray(obj, name, fmt, count, 0, view);
}

void ReleaseArray(Py_buffer* view)
{
	if (view->obj)
	{
		PyBuffer_Release(view);
	}
}

int CopyOut(PyObject* out, const char* name, const void* data, Py_ssize_t count, char fmt)
{
	Py_buffer view;
	if (GetArray(out, name, fmt, count, 1, &view) < 0)
	{
		return -1;
	}
	memcpy(view.buf, data, (size_t)view.len);
	PyBuffer_Release(&view);
	return 0;
}

// ---------------------------------------------------------------------------------------------------------
// Graph

static PyObject* Graph_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "centers", "radii", "edges", "axes", NULL };
	PyObject *centers, *radii, *edges, *axes = Py_None;
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOO|O", keywords, &centers, &radii, &edges, &axes))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	Py_ssize_t n = ItemCount(centers, "centers", 24), m = ItemCount(edges, "edges", 8);
	if (n < 0 || m < 0)
	{
		return NULL;
	}
	Py_buffer cv, rv, ev, av;
	if (GetArray(centers, "centers", 'd', 3 * n, 0, &cv) < 0)
	{
		return NULL;
	}
	if (GetArray(radii, "radii", 'd', 3 * n, 0, &rv) < 0)
	{
		PyBuffer_Release(&cv);
		return NULL;
	}
	if (GetArray(edges, "edges", 'i', 2 * m, 0, &ev) < 0 || GetOptionalArray(axes, "axes", 'd', 9 * n, &av) < 0)
	{
		ReleaseArray(&ev);
		PyBuffer_Release(&cv);
		PyBuffer_Release(&rv);
		return NULL;
	}
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = (int)n;
	def.centers = cv.buf;
	def.radii = rv.buf;
	def.axes = av.obj ? av.buf : NULL;
	def.edgeCount = (int)m;
	def.edges = ev.buf;
	od_Graph* graph = NULL;
	PyThreadState* ts = PyEval_SaveThread();
	od_Status status = od_Graph_Create(&def, &graph);
	PyEval_RestoreThread(ts);
	PyBuffer_Release(&cv);
	PyBuffer_Release(&rv);
	PyBuffer_Release(&ev);
	ReleaseArray(&av);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	GraphObject* self = (GraphObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_Graph_Destroy(graph);
		return NULL;
	}
	self->graph = graph;
	return (PyObject*)self;
}

static void Graph_dealloc(PyObject* obj)
{
	GraphObject* self = (GraphObject*)obj;
	PyTypeObject* type = Py_TYPE(obj);
	od_Graph_Destroy(self->graph);
	freefunc tp_free = (freefunc)PyType_GetSlot(type, Py_tp_free);
	tp_free(obj);
	Py_DECREF(type);
}

static PyObject* Graph_get_n_particles(PyObject* obj, void* closure)
{
	(void)closure;
	return PyLong_FromLong(od_Graph_GetParticleCount(((GraphObject*)obj)->graph));
}

static PyObject* Graph_get_n_edges(PyObject* obj, void* closure)
{
	(void)closure;
	return PyLong_FromLong(od_Graph_GetEdgeCount(((GraphObject*)obj)->graph));
}

// Graph.read(name, out): copies "centers", "radii", "axes", "edges", "pieces" or "mesh_pieces" into a writable
// buffer.
static PyObject* Graph_read(PyObject* obj, PyObject* args)
{
	const od_Graph* g = ((GraphObject*)obj)->graph;
	const char* name;
	PyObject* out;
	if (!PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	Py_ssize_t n = od_Graph_GetParticleCount(g), m = od_Graph_GetEdgeCount(g);
	int rc;
	if (strcmp(name, "centers") == 0)
	{
		rc = CopyOut(out, "out", od_Graph_GetCenters(g), 3 * n, 'd');
	}
	else if (strcmp(name, "radii") == 0)
	{
		rc = CopyOut(out, "out", od_Graph_GetRadii(g), 3 * n, 'd');
	}
	else if (strcmp(name, "axes") == 0)
	{
		rc = CopyOut(out, "out", od_Graph_GetAxes(g), 9 * n, 'd');
	}
	else if (strcmp(name, "edges") == 0)
	{
		rc = CopyOut(out, "out", od_Graph_GetEdges(g), 2 * m, 'i');
	}
	else if (strcmp(name, "pieces") == 0 || strcmp(name, "mesh_pieces") == 0)
	{
		Py_buffer view;
		rc = GetArray(out, "out", 'i', n, 1, &view);
		if (rc == 0)
		{
			(name[0] == 'p' ? od_Graph_GetPieces : od_Graph_GetMeshPieces)(g, view.buf);
			PyBuffer_Release(&view);
		}
	}
	else
	{
		PyErr_Format(PyExc_ValueError, "unknown graph array '%s'", name);
		rc = -1;
	}
	if (rc < 0)
	{
		return NULL;
	}
	Py_RETURN_NONE;
}

static PyObject* Graph_piece_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	return PyLong_FromLong(od_Graph_GetPieces(((GraphObject*)obj)->graph, NULL));
}

static PyObject* Graph_mesh_piece_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	return PyLong_FromLong(od_Graph_GetMeshPieces(((GraphObject*)obj)->graph, NULL));
}

// Graph.skin_weights(point, m, idx_out(int32 m), w_out(float64 m)) -> count
static PyObject* Graph_skin_weights(PyObject* obj, PyObject* args)
{
	double p[3];
	int m;
	PyObject *idxOut, *wOut;
	if (!PyArg_ParseTuple(args, "(ddd)iOO", &p[0], &p[1], &p[2], &m, &idxOut, &wOut))
	{
		return NULL;
	}
	if (m < 1 || m > 16)
	{
		PyErr_Format(PyExc_ValueError, "m = %d must be in [1, 16]", m);
		return NULL;
	}
	int idx[16];
	double w[16];
	int count = od_Graph_SkinWeights(((GraphObject*)obj)->graph, p, m, idx, w);
	if (CopyOut(idxOut, "idx", idx, count, 'i') < 0 || CopyOut(wOut, "w", w, count, 'd') < 0)
	{
		return NULL;
	}
	return PyLong_FromLong(count);
}

static PyGetSetDef Graph_getset[] = {
	{ "n_particles", Graph_get_n_particles, NULL, "number of particles", NULL },
	{ "n_edges", Graph_get_n_edges, NULL, "number of undirected edges", NULL },
	{ NULL, NULL, NULL, NULL, NULL },
};

static PyMethodDef Graph_methods[] = {
	{ "read", Graph_read, METH_VARARGS, "read(name, out): copy a graph array into a writable buffer" },
	{ "piece_count", Graph_piece_count, METH_NOARGS, "number of connected pieces" },
	{ "mesh_piece_count", Graph_mesh_piece_count, METH_NOARGS, "number of mesh pieces (0: not from a mesh)" },
	{ "skin_weights", Graph_skin_weights, METH_VARARGS, "skin_weights(point, m, idx_out, w_out) -> count" },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Graph_slots[] = {
	{ Py_tp_doc, "Rest graph of ellipsoid particles (immutable)." },
	{ Py_tp_new, Graph_new },
	{ Py_tp_dealloc, Graph_dealloc },
	{ Py_tp_getset, Graph_getset },
	{ Py_tp_methods, Graph_methods },
	{ 0, NULL },
};

static PyType_Spec Graph_spec = {
	.name = "opdeform._core.Graph",
	.basicsize = sizeof(GraphObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Graph_slots,
};

// ---------------------------------------------------------------------------------------------------------
// Simulation

static PyObject* SimModule(PyObject* obj)
{
	return PyType_GetModule(Py_TYPE(obj));
}

// Guards against use from another thread while this object's GIL-free call runs.
int SimEnter(SimObject* self)
{
	if (self->busy)
	{
		PyErr_SetString(PyExc_RuntimeError, "the simulation is being used by another thread");
		return -1;
	}
	return 0;
}

static int ParseDef(PyObject* args, PyObject* kwargs, PyObject** graph, od_SimDef* def)
{
	static char* keywords[] = { "graph", "stiffness", "density", "dt", "iterations", "gravity", "damping",
								"skin_neighbors", NULL };
	*def = od_DefaultSimDef();
	return PyArg_ParseTupleAndKeywords(args, kwargs, "Od|ddi(ddd)di", keywords, graph, &def->stiffness, &def->density,
									   &def->dt, &def->iterations, &def->gravity[0], &def->gravity[1],
									   &def->gravity[2], &def->damping, &def->skinNeighbors);
}

static PyObject* Sim_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	PyObject* graph;
	od_SimDef def;
	if (!ParseDef(args, kwargs, &graph, &def))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	if (!PyObject_TypeCheck(graph, GetState(module)->graphType))
	{
		PyErr_SetString(PyExc_TypeError, "graph must be an opdeform._core.Graph");
		return NULL;
	}
	od_Sim* sim = NULL;
	od_Status status = od_Sim_Create(((GraphObject*)graph)->graph, &def, &sim);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	SimObject* self = (SimObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_Sim_Destroy(sim);
		return NULL;
	}
	self->sim = sim;
	Py_INCREF(graph);
	self->graph = graph;
	return (PyObject*)self;
}

static void Sim_dealloc(PyObject* obj)
{
	SimObject* self = (SimObject*)obj;
	PyTypeObject* type = Py_TYPE(obj);
	od_Sim_Destroy(self->sim);
	Py_XDECREF(self->graph);
	freefunc tp_free = (freefunc)PyType_GetSlot(type, Py_tp_free);
	tp_free(obj);
	Py_DECREF(type);
}

static PyObject* Done(PyObject* obj, od_Status status)
{
	if (status != OD_OK)
	{
		return RaiseStatus(SimModule(obj), status);
	}
	Py_RETURN_NONE;
}

static PyObject* IdOrRaise(PyObject* obj, od_Status status, int id)
{
	return status == OD_OK ? PyLong_FromLong(id) : RaiseStatus(SimModule(obj), status);
}

// add_position_constraint((x,y,z), target or None, weight) -> id
static PyObject* Sim_add_position_constraint(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	double p[3], t[3], weight;
	PyObject* target;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "(ddd)Od", &p[0], &p[1], &p[2], &target, &weight))
	{
		return NULL;
	}
	if (target != Py_None && !PyArg_ParseTuple(target, "ddd", &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_Sim_AddPositionConstraint(self->sim, p, target == Py_None ? NULL : t, weight, &id);
	return IdOrRaise(obj, status, id);
}

// add_direction_constraint((x,y,z), (dx,dy,dz), target or None, weight) -> id
static PyObject* Sim_add_direction_constraint(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	double p[3], d[3], t[3], weight;
	PyObject* target;
	if (SimEnter(self) < 0 ||
		!PyArg_ParseTuple(args, "(ddd)(ddd)Od", &p[0], &p[1], &p[2], &d[0], &d[1], &d[2], &target, &weight))
	{
		return NULL;
	}
	if (target != Py_None && !PyArg_ParseTuple(target, "ddd", &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_Sim_AddDirectionConstraint(self->sim, p, d, target == Py_None ? NULL : t, weight, &id);
	return IdOrRaise(obj, status, id);
}

static PyObject* Sim_set_constraint_target(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	int id;
	double t[3];
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "i(ddd)", &id, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	return Done(obj, od_Sim_SetConstraintTarget(self->sim, id, t));
}

static PyObject* Sim_set_constraint_weight(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	int id;
	double w;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "id", &id, &w))
	{
		return NULL;
	}
	return Done(obj, od_Sim_SetConstraintWeight(self->sim, id, w));
}

static PyObject* Sim_remove_constraint(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	int id;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "i", &id))
	{
		return NULL;
	}
	return Done(obj, od_Sim_RemoveConstraint(self->sim, id));
}

static PyObject* Sim_constraint_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	return PyLong_FromLong(od_Sim_GetConstraintCount(((SimObject*)obj)->sim));
}

static PyObject* Sim_set_floor(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	double height, friction;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "dd", &height, &friction))
	{
		return NULL;
	}
	return Done(obj, od_Sim_SetFloor(self->sim, height, friction));
}

static PyObject* Sim_clear_floor(PyObject* obj, PyObject* unused)
{
	(void)unused;
	SimObject* self = (SimObject*)obj;
	if (SimEnter(self) < 0)
	{
		return NULL;
	}
	od_Sim_ClearFloor(self->sim);
	Py_RETURN_NONE;
}

// Runs step (static = 0) or solve_static (static = 1) with the GIL released.
static PyObject* RunSolver(PyObject* obj, PyObject* args, int isStatic)
{
	SimObject* self = (SimObject*)obj;
	int count;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "i", &count))
	{
		return NULL;
	}
	self->busy = 1;
	PyThreadState* ts = PyEval_SaveThread();
	od_Status status = isStatic ? od_Sim_SolveStatic(self->sim, count) : od_Sim_Step(self->sim, count);
	PyEval_RestoreThread(ts);
	self->busy = 0;
	return Done(obj, status);
}

static PyObject* Sim_step(PyObject* obj, PyObject* args)
{
	return RunSolver(obj, args, 0);
}

static PyObject* Sim_solve_static(PyObject* obj, PyObject* args)
{
	return RunSolver(obj, args, 1);
}

static PyObject* Sim_set_state(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	PyObject *pos, *rot, *vel = Py_None, *ang = Py_None;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "OO|OO", &pos, &rot, &vel, &ang))
	{
		return NULL;
	}
	Py_ssize_t n = od_Graph_GetParticleCount(((GraphObject*)self->graph)->graph);
	Py_buffer pv, rv, vv, av;
	if (GetArray(pos, "positions", 'd', 3 * n, 0, &pv) < 0)
	{
		return NULL;
	}
	if (GetArray(rot, "rotations", 'd', 9 * n, 0, &rv) < 0)
	{
		PyBuffer_Release(&pv);
		return NULL;
	}
	if (GetOptionalArray(vel, "velocities", 'd', 3 * n, &vv) < 0)
	{
		PyBuffer_Release(&pv);
		PyBuffer_Release(&rv);
		return NULL;
	}
	if (GetOptionalArray(ang, "angular_velocities", 'd', 3 * n, &av) < 0)
	{
		PyBuffer_Release(&pv);
		PyBuffer_Release(&rv);
		ReleaseArray(&vv);
		return NULL;
	}
	od_Status status =
		od_Sim_SetState(self->sim, pv.buf, rv.buf, vv.obj ? vv.buf : NULL, av.obj ? av.buf : NULL);
	PyBuffer_Release(&pv);
	PyBuffer_Release(&rv);
	ReleaseArray(&vv);
	ReleaseArray(&av);
	return Done(obj, status);
}

// read(name, out): "positions", "rotations", "velocities", "angular_velocities" or "energy_trace".
static PyObject* Sim_read(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	const char* name;
	PyObject* out;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	Py_ssize_t n = od_Graph_GetParticleCount(((GraphObject*)self->graph)->graph);
	const double* data = NULL;
	Py_ssize_t count = 3 * n;
	if (strcmp(name, "positions") == 0)
	{
		data = od_Sim_GetPositions(self->sim);
	}
	else if (strcmp(name, "rotations") == 0)
	{
		data = od_Sim_GetRotations(self->sim);
		count = 9 * n;
	}
	else if (strcmp(name, "velocities") == 0)
	{
		data = od_Sim_GetVelocities(self->sim);
	}
	else if (strcmp(name, "angular_velocities") == 0)
	{
		data = od_Sim_GetAngularVelocities(self->sim);
	}
	else if (strcmp(name, "energy_trace") == 0)
	{
		int traceCount = 0;
		data = od_Sim_GetEnergyTrace(self->sim, &traceCount);
		count = traceCount;
	}
	else
	{
		PyErr_Format(PyExc_ValueError, "unknown state array '%s'", name);
		return NULL;
	}
	if (count > 0 && CopyOut(out, "out", data, count, 'd') < 0)
	{
		return NULL;
	}
	return PyLong_FromSsize_t(count);
}

static PyObject* Sim_trace_length(PyObject* obj, PyObject* unused)
{
	(void)unused;
	int count = 0;
	od_Sim_GetEnergyTrace(((SimObject*)obj)->sim, &count);
	return PyLong_FromLong(count);
}

static PyObject* Sim_set_energy_trace(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	int enabled;
	if (SimEnter(self) < 0 || !PyArg_ParseTuple(args, "p", &enabled))
	{
		return NULL;
	}
	od_Sim_SetEnergyTrace(self->sim, enabled);
	Py_RETURN_NONE;
}

static PyObject* Sim_energy(PyObject* obj, PyObject* unused)
{
	(void)unused;
	SimObject* self = (SimObject*)obj;
	if (SimEnter(self) < 0)
	{
		return NULL;
	}
	return PyFloat_FromDouble(od_Sim_GetEnergy(self->sim));
}

static PyObject* Sim_params(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_SimDef d = od_Sim_GetDef(((SimObject*)obj)->sim);
	return Py_BuildValue("{sdsdsdsis(ddd)sdsi}", "stiffness", d.stiffness, "density", d.density, "dt", d.dt,
						 "iterations", d.iterations, "gravity", d.gravity[0], d.gravity[1], d.gravity[2], "damping",
						 d.damping, "skin_neighbors", d.skinNeighbors);
}

// set_params(stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sim_set_params(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	od_SimDef d;
	if (SimEnter(self) < 0 ||
		!PyArg_ParseTuple(args, "dddi(ddd)di", &d.stiffness, &d.density, &d.dt, &d.iterations, &d.gravity[0],
						  &d.gravity[1], &d.gravity[2], &d.damping, &d.skinNeighbors))
	{
		return NULL;
	}
	return Done(obj, od_Sim_SetDef(self->sim, &d));
}

static PyObject* Sim_counters(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_SimCounters c = od_Sim_GetCounters(((SimObject*)obj)->sim);
	return Py_BuildValue("{sLsLsLsLsLsLsLsdsd}", "factorizations", c.factorizations, "analyses", c.analyses,
						 "solves", c.solves, "steps", c.steps, "polar_fallbacks", c.polarFallbacks, "accelerated",
						 c.accelerated, "rejected", c.rejected, "local_seconds", c.localSeconds, "global_seconds",
						 c.globalSeconds);
}

// set_solver(accelerator: 0 none | 1 anderson | 2 chebyshev, window, rho, threads, factorization)
static PyObject* Sim_set_solver(PyObject* obj, PyObject* args)
{
	SimObject* self = (SimObject*)obj;
	od_SolverDef d = od_DefaultSolverDef();
	int kind;
	if (SimEnter(self) < 0 ||
		!PyArg_ParseTuple(args, "iidii", &kind, &d.window, &d.rho, &d.threads, &d.factorization))
	{
		return NULL;
	}
	d.accelerator = (od_AcceleratorKind)kind;
	return Done(obj, od_Sim_SetSolver(self->sim, &d));
}

static PyObject* Sim_solver(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_SolverDef d = od_Sim_GetSolver(((SimObject*)obj)->sim);
	return Py_BuildValue("{sisisdsisi}", "accelerator", (int)d.accelerator, "window", d.window, "rho", d.rho,
						 "threads", d.threads, "factorization", d.factorization);
}

static PyMethodDef Sim_methods[] = {
	{ "add_position_constraint", Sim_add_position_constraint, METH_VARARGS, NULL },
	{ "add_direction_constraint", Sim_add_direction_constraint, METH_VARARGS, NULL },
	{ "set_constraint_target", Sim_set_constraint_target, METH_VARARGS, NULL },
	{ "set_constraint_weight", Sim_set_constraint_weight, METH_VARARGS, NULL },
	{ "remove_constraint", Sim_remove_constraint, METH_VARARGS, NULL },
	{ "constraint_count", Sim_constraint_count, METH_NOARGS, NULL },
	{ "set_floor", Sim_set_floor, METH_VARARGS, NULL },
	{ "clear_floor", Sim_clear_floor, METH_NOARGS, NULL },
	{ "step", Sim_step, METH_VARARGS, NULL },
	{ "solve_static", Sim_solve_static, METH_VARARGS, NULL },
	{ "set_state", Sim_set_state, METH_VARARGS, NULL },
	{ "read", Sim_read, METH_VARARGS, NULL },
	{ "trace_length", Sim_trace_length, METH_NOARGS, NULL },
	{ "set_energy_trace", Sim_set_energy_trace, METH_VARARGS, NULL },
	{ "energy", Sim_energy, METH_NOARGS, NULL },
	{ "params", Sim_params, METH_NOARGS, NULL },
	{ "set_params", Sim_set_params, METH_VARARGS, NULL },
	{ "counters", Sim_counters, METH_NOARGS, NULL },
	{ "set_solver", Sim_set_solver, METH_VARARGS, NULL },
	{ "solver", Sim_solver, METH_NOARGS, NULL },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Sim_slots[] = {
	{ Py_tp_doc, "ARAP dynamics of an oriented-particle graph (C core)." },
	{ Py_tp_new, Sim_new },
	{ Py_tp_dealloc, Sim_dealloc },
	{ Py_tp_methods, Sim_methods },
	{ 0, NULL },
};

static PyType_Spec Sim_spec = {
	.name = "opdeform._core.Simulation",
	.basicsize = sizeof(SimObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Sim_slots,
};

// ---------------------------------------------------------------------------------------------------------
// Module

static PyObject* Module_allocation_count(PyObject* module, PyObject* unused)
{
	(void)module;
	(void)unused;
	return PyLong_FromLongLong(od_GetAllocationCount());
}

static PyMethodDef module_methods[] = {
	{ "allocation_count", Module_allocation_count, METH_NOARGS, "allocations made by the C core so far" },
	{ NULL, NULL, 0, NULL },
};

static int module_exec(PyObject* module)
{
	ModuleState* st = GetState(module);
	st->graphType = (PyTypeObject*)PyType_FromModuleAndSpec(module, &Graph_spec, NULL);
	st->simType = (PyTypeObject*)PyType_FromModuleAndSpec(module, &Sim_spec, NULL);
	st->solverError = PyErr_NewException("opdeform._core.SolverError", PyExc_RuntimeError, NULL);
	if (!st->graphType || !st->simType || !st->solverError)
	{
		return -1;
	}
	if (PyModule_AddObjectRef(module, "Graph", (PyObject*)st->graphType) < 0 ||
		PyModule_AddObjectRef(module, "Simulation", (PyObject*)st->simType) < 0 ||
		PyModule_AddObjectRef(module, "SolverError", st->solverError) < 0)
	{
		return -1;
	}
	if (Binding_AddMesh(module) < 0)
	{
		return -1;
	}
	if (Binding_AddMpm(module) < 0)
	{
		return -1;
	}
#ifdef OD_BASELINES
	if (Binding_AddShapeMatching(module) < 0)
	{
		return -1;
	}
#endif
	return PyModule_AddStringConstant(module, "__version__", "0.1.0");
}

static int module_traverse(PyObject* module, visitproc visit, void* arg)
{
	ModuleState* st = GetState(module);
	Py_VISIT(st->graphType);
	Py_VISIT(st->simType);
	Py_VISIT(st->solverError);
	return 0;
}

static int module_clear(PyObject* module)
{
	ModuleState* st = GetState(module);
	Py_CLEAR(st->graphType);
	Py_CLEAR(st->simType);
	Py_CLEAR(st->solverError);
	return 0;
}

static void module_free(void* module)
{
	module_clear((PyObject*)module);
}

static PyModuleDef_Slot module_slots[] = {
	{ Py_mod_exec, module_exec },
	{ 0, NULL },
};

static struct PyModuleDef module_def = {
	PyModuleDef_HEAD_INIT,
	.m_name = "_core",
	.m_doc = "opdeform C core binding (limited API).",
	.m_size = sizeof(ModuleState),
	.m_methods = module_methods,
	.m_slots = module_slots,
	.m_traverse = module_traverse,
	.m_clear = module_clear,
	.m_free = module_free,
};

PyMODINIT_FUNC PyInit__core(void)
{
	return PyModuleDef_Init(&module_def);
}
