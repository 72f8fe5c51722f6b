// opdeform._core.Graph: the immutable rest graph (csrc/include/opdeform/opdeform.h). Shared read-only by
// any number of simulations, skins and threads, so it has no busy guard; building it releases the GIL.
#include "graph_binding.h"

#include <string.h>

typedef struct
{
	PyObject_HEAD od_Graph* graph;
} GraphObject;

const od_Graph* Graph_FromObject(PyObject* module, PyObject* obj)
{
	if (!PyObject_TypeCheck(obj, Binding_State(module)->graphType))
	{
		PyErr_SetString(PyExc_TypeError, "graph must be an opdeform._core.Graph");
		return NULL;
	}
	return ((GraphObject*)obj)->graph;
}

PyObject* Graph_Wrap(PyObject* module, od_Graph* graph)
{
	GraphObject* self = (GraphObject*)PyType_GenericAlloc(Binding_State(module)->graphType, 0);
	if (!self)
	{
		od_Graph_Destroy(graph);
		return NULL;
	}
	self->graph = graph;
	return (PyObject*)self;
}

static PyObject* Graph_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "centers", "radii", "edges", "axes", NULL };
	PyObject* arrays[4] = { NULL, NULL, NULL, Py_None };
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOO|O", keywords, &arrays[0], &arrays[1], &arrays[2],
									 &arrays[3]))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	Py_ssize_t n = ItemCount(arrays[0], "centers", 24);
	Py_ssize_t m = n < 0 ? -1 : ItemCount(arrays[2], "edges", 8);
	const ArraySpec specs[4] = { { "centers", 'd', 3 * n, 0 }, { "radii", 'd', 3 * n, 0 }, { "edges", 'i', 2 * m, 0 },
								 { "axes", 'd', 9 * n, 1 } };
	Py_buffer views[4];
	if (m < 0 || GetArrays(arrays, specs, 4, views) < 0)
	{
		return NULL;
	}
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = (int)n;
	def.centers = views[0].buf;
	def.radii = views[1].buf;
	def.edgeCount = (int)m;
	def.edges = views[2].buf;
	def.axes = ArrayData(&views[3]);
	od_Graph* graph = NULL;
	PyThreadState* ts = PyEval_SaveThread();
	od_Status status = od_Graph_Create(&def, &graph);
	PyEval_RestoreThread(ts);
	ReleaseArrays(views, 4);
	return status == OD_OK ? Graph_Wrap(module, graph) : RaiseStatus(module, status);
}

static void Graph_dealloc(PyObject* obj)
{
	od_Graph_Destroy(((GraphObject*)obj)->graph);
	Binding_Free(obj);
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

// Copies the labels of the connected pieces into an int32 buffer of n.
// The graph's own connected pieces ("pieces") or the mesh piece of each particle ("mesh_pieces").
static int ReadPieces(const od_Graph* g, PyObject* out, Py_ssize_t n, int (*get)(const od_Graph*, int*))
{
	Py_buffer view;
	if (GetArray(out, "out", 'i', n, 1, &view) < 0)
	{
		return -1;
	}
	get(g, view.buf);
	PyBuffer_Release(&view);
	return 0;
}

static PyObject* Graph_mesh_piece_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	return PyLong_FromLong(od_Graph_GetMeshPieces(((GraphObject*)obj)->graph, NULL));
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
		rc = ReadPieces(g, out, n, name[0] == 'p' ? od_Graph_GetPieces : od_Graph_GetMeshPieces);
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

// Graph.skin_weights(point, m, idx_out(int32 m), w_out(float64 m)) -> count (the first count entries written)
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
	// Written in place: the count is min(m, particles), known only afterwards.
	Py_buffer views[2];
	if (GetArray(idxOut, "idx", 'i', m, 1, &views[0]) < 0)
	{
		return NULL;
	}
	if (GetArray(wOut, "w", 'd', m, 1, &views[1]) < 0)
	{
		ReleaseArray(&views[0]);
		return NULL;
	}
	int count = od_Graph_SkinWeights(((GraphObject*)obj)->graph, p, m, views[0].buf, views[1].buf);
	ReleaseArrays(views, 2);
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

PyType_Spec Graph_Spec = {
	.name = "opdeform._core.Graph",
	.basicsize = sizeof(GraphObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Graph_slots,
};
