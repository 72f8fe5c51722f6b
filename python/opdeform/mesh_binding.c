// opdeform._core, mesh part: graph_from_mesh, the Skin type, parse_mesh and format_mesh (csrc mesh.h).
//
// Thin like the rest of the binding: buffers in (checked for size and format), the GIL released around
// the C calls, status codes to exceptions. Outputs of Skin.deform may be float32 or float64 buffers, so
// that Blender's foreach_set can take them in one block; the mesh parsers return bytearrays that the
// Python layer views as numpy arrays without a copy.
#include "graph_binding.h"
#include "mesh_binding.h"

#include "opdeform/mesh.h"

#include <limits.h>
#include <string.h>

// A C-contiguous float32 or float64 buffer of `count` items; its type in *type.
static int GetFloatArray(PyObject* obj, const char* name, Py_ssize_t count, int writable, Py_buffer* view,
						 od_Scalar* type)
{
	*type = OD_FLOAT64;
	if (GetArray(obj, name, 'd', count, writable, view) == 0)
	{
		return 0;
	}
	PyErr_Clear();
	*type = OD_FLOAT32;
	if (GetArray(obj, name, 'f', count, writable, view) == 0)
	{
		return 0;
	}
	PyErr_Clear();
	PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous%s float32 or float64 buffer of %zd values", name,
				 writable ? ", writable" : "", count);
	return -1;
}

// The buffers of a mesh: vertices (float64, V*3) and triangles (int32, T*3; None allowed when optional, then
// T = 0). On failure nothing is held and an exception is set.
static int GetMesh(PyObject* vertices, PyObject* triangles, int optional, Py_buffer* vv, Py_buffer* tv, int* nv,
				   int* nt)
{
	memset(tv, 0, sizeof *tv);
	Py_ssize_t v = ItemCount(vertices, "vertices", 24);
	Py_ssize_t t = v < 0 ? -1 : optional && triangles == Py_None ? 0 : ItemCount(triangles, "triangles", 12);
	if (t < 0)
	{
		return -1;
	}
	if (v > INT_MAX / 3 || t > INT_MAX / 3)
	{
		PyErr_SetString(PyExc_ValueError, "the mesh is too large");
		return -1;
	}
	if (GetArray(vertices, "vertices", 'd', 3 * v, 0, vv) < 0)
	{
		return -1;
	}
	if ((!optional || triangles != Py_None) && GetArray(triangles, "triangles", 'i', 3 * t, 0, tv) < 0)
	{
		PyBuffer_Release(vv);
		return -1;
	}
	*nv = (int)v;
	*nt = (int)t;
	return 0;
}

// ---------------------------------------------------------------------------------------------------------
// Graph from a mesh

// graph_from_mesh(vertices, triangles, particles, mode, join_pieces, voxels_per_particle, small_pieces) -> Graph
static PyObject* Mesh_graph_from_mesh(PyObject* module, PyObject* args)
{
	PyObject *vertices, *triangles;
	int particles, mode, join, voxels, small;
	if (!PyArg_ParseTuple(args, "OOiipii", &vertices, &triangles, &particles, &mode, &join, &voxels, &small))
	{
		return NULL;
	}
	Py_buffer vv, tv;
	int nv, nt;
	if (GetMesh(vertices, triangles, 0, &vv, &tv, &nv, &nt) < 0)
	{
		return NULL;
	}
	od_MeshGraphDef def = od_DefaultMeshGraphDef();
	def.vertexCount = nv;
	def.vertices = vv.buf;
	def.triangleCount = nt;
	def.triangles = tv.buf;
	def.particleCount = particles;
	def.mode = (od_MeshGraphMode)mode;
	def.joinPieces = join;
	def.voxelsPerParticle = voxels;
	def.smallPieces = (od_SmallPieces)small;
	od_Graph* graph = NULL;
	PyThreadState* ts = Binding_Release(); // seconds for a million triangles or voxels; Ctrl-C polled
	od_Status status = od_Graph_CreateFromMesh(&def, &graph);
	Binding_Reacquire(ts);
	PyBuffer_Release(&vv);
	PyBuffer_Release(&tv);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	return Graph_Wrap(module, graph);
}

// ---------------------------------------------------------------------------------------------------------
// Skin

typedef struct
{
	GuardedObject head; // busy while a GIL-free deform runs (the skin's threads serve one call at a time)
	od_Skin* skin;
} SkinObject;

// The od_Skin of obj, or NULL with RuntimeError while a deform on another thread runs.
static od_Skin* Skin_Enter(PyObject* obj)
{
	return Binding_Enter(obj) < 0 ? NULL : ((SkinObject*)obj)->skin;
}

// Skin(graph, vertices, neighbors, triangles=None, normals=None, threads=0)
static PyObject* Skin_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "graph", "vertices", "neighbors", "triangles", "normals", "threads", NULL };
	PyObject *graphObj, *vertices, *triangles = Py_None, *normals = Py_None;
	int neighbors, threads = 0;
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOi|OOi", keywords, &graphObj, &vertices, &neighbors, &triangles,
									 &normals, &threads))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	const od_Graph* graph = Graph_FromObject(module, graphObj);
	Py_buffer vv, tv, nview;
	int nv, nt;
	if (!graph || GetMesh(vertices, triangles, 1, &vv, &tv, &nv, &nt) < 0)
	{
		return NULL;
	}
	if (GetOptionalArray(normals, "normals", 'd', 3 * (Py_ssize_t)nv, &nview) < 0)
	{
		PyBuffer_Release(&vv);
		ReleaseArray(&tv);
		return NULL;
	}
	od_SkinDef def = od_DefaultSkinDef();
	def.vertexCount = nv;
	def.vertices = vv.buf;
	def.triangleCount = nt;
	def.triangles = ArrayData(&tv);
	def.normals = ArrayData(&nview);
	def.neighbors = neighbors;
	def.threadCount = threads;
	od_Skin* skin = NULL;
	PyThreadState* ts = Binding_Release(); // 0.4 s for 499,002 vertices; Ctrl-C polled
	od_Status status = od_Skin_Create(graph, &def, &skin);
	Binding_Reacquire(ts);
	PyBuffer_Release(&vv);
	ReleaseArray(&tv);
	ReleaseArray(&nview);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	SkinObject* self = (SkinObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_Skin_Destroy(skin);
		return NULL;
	}
	self->skin = skin;
	return (PyObject*)self;
}

static void Skin_dealloc(PyObject* obj)
{
	od_Skin_Destroy(((SkinObject*)obj)->skin);
	Binding_Free(obj);
}

// The counts a Skin reports; a getter's closure points at one of them.
typedef int (*SkinCount)(const od_Skin* skin);
static const SkinCount SkinCounts[3] = { od_Skin_GetVertexCount, od_Skin_GetParticleCount, od_Skin_GetNeighborCount };

static PyObject* Skin_get_count(PyObject* obj, void* closure)
{
	const od_Skin* skin = Skin_Enter(obj);
	return skin ? PyLong_FromLong((*(const SkinCount*)closure)(skin)) : NULL;
}

static PyObject* Skin_get_has_rest_normals(PyObject* obj, void* closure)
{
	(void)closure;
	const od_Skin* skin = Skin_Enter(obj);
	return skin ? PyBool_FromLong(od_Skin_GetRestNormals(skin) != NULL) : NULL;
}

// read(name, out): "indices" (int32 V*m), "weights" (float64 V*m) or "rest_normals" (float64 V*3).
static PyObject* Skin_read(PyObject* obj, PyObject* args)
{
	const od_Skin* skin = Skin_Enter(obj);
	const char* name;
	PyObject* out;
	if (!skin || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	Py_ssize_t nv = od_Skin_GetVertexCount(skin), m = od_Skin_GetNeighborCount(skin);
	int rc;
	if (strcmp(name, "indices") == 0)
	{
		rc = CopyOut(out, "out", od_Skin_GetIndices(skin), nv * m, 'i');
	}
	else if (strcmp(name, "weights") == 0)
	{
		rc = CopyOut(out, "out", od_Skin_GetWeights(skin), nv * m, 'd');
	}
	else if (strcmp(name, "rest_normals") == 0 && od_Skin_GetRestNormals(skin))
	{
		rc = CopyOut(out, "out", od_Skin_GetRestNormals(skin), 3 * nv, 'd');
	}
	else
	{
		PyErr_Format(PyExc_ValueError, "no skin array '%s'", name);
		rc = -1;
	}
	if (rc < 0)
	{
		return NULL;
	}
	Py_RETURN_NONE;
}

// deform(positions, rotations, out, normals_out=None, rest_normals=None)
static PyObject* Skin_deform(PyObject* obj, PyObject* args)
{
	od_Skin* skin = Skin_Enter(obj);
	PyObject *positions, *rotations, *out, *normalsOut = Py_None, *restNormals = Py_None;
	if (!skin || !PyArg_ParseTuple(args, "OOO|OO", &positions, &rotations, &out, &normalsOut, &restNormals))
	{
		return NULL;
	}
	Py_ssize_t n = od_Skin_GetParticleCount(skin), nv = od_Skin_GetVertexCount(skin);
	Py_buffer pv, rv, ov, nview, rnview;
	memset(&nview, 0, sizeof nview);
	memset(&rnview, 0, sizeof rnview);
	od_SkinTarget target;
	memset(&target, 0, sizeof target);
	if (GetArray(positions, "positions", 'd', 3 * n, 0, &pv) < 0)
	{
		return NULL;
	}
	if (GetArray(rotations, "rotations", 'd', 9 * n, 0, &rv) < 0)
	{
		PyBuffer_Release(&pv);
		return NULL;
	}
	if (GetFloatArray(out, "out", 3 * nv, 1, &ov, &target.positionType) < 0 ||
		(normalsOut != Py_None &&
		 GetFloatArray(normalsOut, "normals_out", 3 * nv, 1, &nview, &target.normalType) < 0) ||
		(restNormals != Py_None &&
		 GetFloatArray(restNormals, "rest_normals", 3 * nv, 0, &rnview, &target.restNormalType) < 0))
	{
		ReleaseArray(&ov);
		ReleaseArray(&nview);
		PyBuffer_Release(&pv);
		PyBuffer_Release(&rv);
		return NULL;
	}
	target.positions = ov.buf;
	target.normals = ArrayData(&nview);
	target.restNormals = ArrayData(&rnview);
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = od_Skin_Deform(skin, pv.buf, rv.buf, &target);
	Binding_End(obj, ts);
	PyBuffer_Release(&pv);
	PyBuffer_Release(&rv);
	PyBuffer_Release(&ov);
	ReleaseArray(&nview);
	ReleaseArray(&rnview);
	return Binding_Done(obj, status);
}

// shown_offset(skinned, reference, lock, input, offset, out): od_ShownOffset over the skin's vertices, or, where
// reference is a pair (positions, rotations) of particle frames, od_Skin_DeformShown (their skin made in the pass)
static PyObject* Skin_shown_offset(PyObject* obj, PyObject* args)
{
	od_Skin* skin = Skin_Enter(obj);
	PyObject *reference, *arrays[7];
	if (!skin || !PyArg_ParseTuple(args, "OOOOOO", &arrays[0], &reference, &arrays[3], &arrays[4], &arrays[5],
								   &arrays[6]))
	{
		return NULL;
	}
	int frames = PyTuple_Check(reference) && PyTuple_Size(reference) == 2;
	arrays[1] = frames ? PyTuple_GetItem(reference, 0) : reference;
	arrays[2] = frames ? PyTuple_GetItem(reference, 1) : Py_None;
	Py_ssize_t n = od_Skin_GetParticleCount(skin), count = 3 * (Py_ssize_t)od_Skin_GetVertexCount(skin);
	ArraySpec specs[5] = { { "skinned", 'd', count, 0 }, { "reference", 'd', count, 0 }, { "rotations", 'd', 9 * n, 1 },
						   { "lock", 'd', count, 1 }, { "input", 'f', count, 0 } };
	if (frames)
	{
		specs[1].name = "positions";
		specs[1].count = 3 * n;
		specs[2].optional = 0;
	}
	const ArraySpec outSpecs[2] = { { "offset", 'f', count, 0 }, { "out", 'f', count, 0 } };
	Py_buffer views[5], outViews[2];
	if (GetInOutArrays(arrays, specs, 5, views, outSpecs, 2, outViews) < 0)
	{
		return NULL;
	}
	od_Status status = OD_OK;
	if (frames)
	{
		PyThreadState* ts = Binding_Begin(obj);
		status = od_Skin_DeformShown(skin, views[1].buf, views[2].buf, views[0].buf, ArrayData(&views[3]),
									 views[4].buf, outViews[0].buf, outViews[1].buf);
		Binding_End(obj, ts);
	}
	else
	{
		od_ShownOffset((int)(count / 3), views[0].buf, views[1].buf, ArrayData(&views[3]), views[4].buf,
					   outViews[0].buf, outViews[1].buf);
	}
	ReleaseArrays(views, 5);
	ReleaseArrays(outViews, 2);
	return Binding_Done(obj, status);
}

static PyGetSetDef Skin_getset[] = {
	{ "n_vertices", Skin_get_count, NULL, "number of bound vertices", (void*)&SkinCounts[0] },
	{ "n_particles", Skin_get_count, NULL, "number of particles of the graph", (void*)&SkinCounts[1] },
	{ "neighbors", Skin_get_count, NULL, "particles per vertex (m)", (void*)&SkinCounts[2] },
	{ "has_rest_normals", Skin_get_has_rest_normals, NULL, "whether rest normals were given at binding", NULL },
	{ NULL, NULL, NULL, NULL, NULL },
};

static PyMethodDef Skin_methods[] = {
	{ "read", Skin_read, METH_VARARGS, "read(name, out): copy 'indices', 'weights' or 'rest_normals'" },
	{ "deform", Skin_deform, METH_VARARGS, "deform(positions, rotations, out, normals_out=None, rest_normals=None)" },
	{ "shown_offset", Skin_shown_offset, METH_VARARGS,
	  "shown_offset(skinned, reference, lock, input, offset, out): offset = float32((skinned - reference) * lock), "
	  "out = input + offset; reference may be particle (positions, rotations), skinned in the same pass" },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Skin_slots[] = {
	{ Py_tp_doc, "A rest mesh bound to a graph (linear-blend skinning, C core)." },
	{ Py_tp_new, Skin_new },
	{ Py_tp_dealloc, Skin_dealloc },
	{ Py_tp_getset, Skin_getset },
	{ Py_tp_methods, Skin_methods },
	{ 0, NULL },
};

PyType_Spec Skin_Spec = {
	.name = "opdeform._core.Skin",
	.basicsize = sizeof(SkinObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Skin_slots,
};

// ---------------------------------------------------------------------------------------------------------
// OBJ and PLY

// 1 for "ply", 0 for "obj", -1 with ValueError otherwise.
static int ParseFormat(const char* format)
{
	int ply = strcmp(format, "ply") == 0;
	if (!ply && strcmp(format, "obj") != 0)
	{
		PyErr_Format(PyExc_ValueError, "format must be 'obj' or 'ply', got '%s'", format);
		return -1;
	}
	return ply;
}

// parse_mesh(data, format) -> (vertices bytearray of float64 V*3, triangles bytearray of int32 T*3)
static PyObject* Mesh_parse_mesh(PyObject* module, PyObject* args)
{
	Py_buffer data;
	const char* format;
	if (!PyArg_ParseTuple(args, "y*s", &data, &format))
	{
		return NULL;
	}
	int ply = ParseFormat(format);
	if (ply < 0)
	{
		PyBuffer_Release(&data);
		return NULL;
	}
	od_Mesh mesh;
	PyThreadState* ts = Binding_Release(); // 0.4 s for an OBJ of 998,000 triangles; Ctrl-C polled
	od_Status status = ply ? od_Mesh_ParsePly(data.buf, (size_t)data.len, &mesh)
						   : od_Mesh_ParseObj(data.buf, (size_t)data.len, &mesh);
	Binding_Reacquire(ts);
	PyBuffer_Release(&data);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	PyObject* v = PyByteArray_FromStringAndSize((const char*)mesh.vertices,
												(Py_ssize_t)sizeof(double) * 3 * mesh.vertexCount);
	PyObject* t = v ? PyByteArray_FromStringAndSize((const char*)mesh.triangles,
													(Py_ssize_t)sizeof(int) * 3 * mesh.triangleCount)
					: NULL;
	od_Mesh_Free(&mesh);
	PyObject* result = t ? PyTuple_Pack(2, v, t) : NULL;
	Py_XDECREF(v);
	Py_XDECREF(t);
	return result;
}

// format_mesh(format, vertices, triangles) -> bytes
static PyObject* Mesh_format_mesh(PyObject* module, PyObject* args)
{
	const char* format;
	PyObject *vertices, *triangles;
	if (!PyArg_ParseTuple(args, "sOO", &format, &vertices, &triangles))
	{
		return NULL;
	}
	int ply = ParseFormat(format), nv, nt;
	Py_buffer vv, tv;
	if (ply < 0 || GetMesh(vertices, triangles, 0, &vv, &tv, &nv, &nt) < 0)
	{
		return NULL;
	}
	char* text = NULL;
	size_t size = 0;
	PyThreadState* ts = Binding_Release(); // 0.7 s for an OBJ of 998,000 triangles; Ctrl-C polled
	od_Status status = ply ? od_Mesh_FormatPly(nv, vv.buf, nt, tv.buf, &text, &size)
						   : od_Mesh_FormatObj(nv, vv.buf, nt, tv.buf, &text, &size);
	Binding_Reacquire(ts);
	PyBuffer_Release(&vv);
	PyBuffer_Release(&tv);
	if (status != OD_OK)
	{
		return RaiseStatus(module, status);
	}
	PyObject* result = PyBytes_FromStringAndSize(text, (Py_ssize_t)size);
	od_Mesh_FreeData(text);
	return result;
}

PyMethodDef Mesh_Functions[] = {
	{ "graph_from_mesh", Mesh_graph_from_mesh, METH_VARARGS,
	  "graph_from_mesh(vertices, triangles, particles, mode, join_pieces, voxels_per_particle) -> Graph" },
	{ "parse_mesh", Mesh_parse_mesh, METH_VARARGS, "parse_mesh(data, 'obj' | 'ply') -> (vertices, triangles)" },
	{ "format_mesh", Mesh_format_mesh, METH_VARARGS, "format_mesh('obj' | 'ply', vertices, triangles) -> bytes" },
	{ NULL, NULL, 0, NULL },
};

static int Mesh_AddDouble(PyObject* module, const char* name, double value)
{
	PyObject* number = PyFloat_FromDouble(value);
	int status = number ? PyModule_AddObjectRef(module, name, number) : -1;
	Py_XDECREF(number);
	return status;
}

int Mesh_AddConstants(PyObject* module)
{
	if (PyModule_AddIntConstant(module, "SMALL_PIECE_PARTICLES", OD_SMALL_PIECE_PARTICLES) < 0 ||
		PyModule_AddIntConstant(module, "SHELL_PARTICLES", OD_SHELL_PARTICLES) < 0 ||
		PyModule_AddIntConstant(module, "ROOT_LINKS", OD_ROOT_LINKS) < 0 ||
		Mesh_AddDouble(module, "SMALL_PIECE_RATIO", OD_SMALL_PIECE_RATIO) < 0 ||
		Mesh_AddDouble(module, "SMALL_PIECE_SHARE", OD_SMALL_PIECE_SHARE) < 0 ||
		Mesh_AddDouble(module, "SMALL_PIECE_EXTRA", OD_SMALL_PIECE_EXTRA) < 0)
	{
		return -1;
	}
	return 0;
}
