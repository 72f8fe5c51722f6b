// opdeform._core.MpmWorld: the thin binding of the MPM world (csrc/include/opdeform/mpm.h).
//
// Arguments arrive already checked and converted by opdeform/mpm.py: C-contiguous float64/int32 buffers
// and plain numbers. This file only checks buffer sizes, maps status codes to exceptions and releases
// the GIL around the steps, a mesh collider's set-up, adding particles, the orientation update and saving the
// state (the busy guard refuses every call meanwhile).
#include "mpm_binding.h"

#include "opdeform/mpm.h"

#include <string.h>

typedef struct
{
	GuardedObject head;
	od_MpmWorld* world;
} MpmObject;

// The od_MpmWorld of obj, or NULL with RuntimeError while a call on another thread runs.
static od_MpmWorld* Mpm_Enter(PyObject* obj)
{
	return Binding_Enter(obj) < 0 ? NULL : ((MpmObject*)obj)->world;
}

// MpmWorld(lower, upper, dx, gravity, cfl, max_dt, spin, walls, wall_friction, threads)
static PyObject* Mpm_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "lower", "upper", "dx", "gravity", "cfl", "max_dt", "spin", "walls", "wall_friction",
								"threads", NULL };
	od_MpmWorldDef d = od_DefaultMpmWorldDef();
	int walls = (int)d.walls;
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "(ddd)(ddd)d|(ddd)dddidi", keywords, &d.lower[0], &d.lower[1],
									 &d.lower[2], &d.upper[0], &d.upper[1], &d.upper[2], &d.dx, &d.gravity[0],
									 &d.gravity[1], &d.gravity[2], &d.cfl, &d.maxDt, &d.spin, &walls, &d.wallFriction,
									 &d.threads))
	{
		return NULL;
	}
	d.walls = (od_MpmContact)walls;
	od_MpmWorld* world = NULL;
	od_Status status = od_MpmWorld_Create(&d, &world);
	if (status != OD_OK)
	{
		return RaiseStatus(PyType_GetModule(type), status);
	}
	MpmObject* self = (MpmObject*)PyType_GenericAlloc(type, 0);
	if (!self)
	{
		od_MpmWorld_Destroy(world);
		return NULL;
	}
	self->world = world;
	return (PyObject*)self;
}

static void Mpm_dealloc(PyObject* obj)
{
	od_MpmWorld_Destroy(((MpmObject*)obj)->world);
	Binding_Free(obj);
}

// add_particles(positions, velocities|None, affine|None, orientations|None, particle_volume,
//               (kind, density, young, poisson, critical_compression, critical_stretch, hardening))
static PyObject* Mpm_add_particles(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	PyObject* arrays[4]; // positions, velocities, affine, orientations
	od_MpmParticlesDef d = od_DefaultMpmParticlesDef();
	od_MpmMaterial* m = &d.material;
	int kind;
	if (!world ||
		!PyArg_ParseTuple(args, "OOOOd(idddddd)", &arrays[0], &arrays[1], &arrays[2], &arrays[3], &d.particleVolume,
						  &kind, &m->density, &m->youngModulus, &m->poissonRatio, &m->criticalCompression,
						  &m->criticalStretch, &m->hardening))
	{
		return NULL;
	}
	m->kind = (od_MpmMaterialKind)kind;
	Py_ssize_t n = ItemCount(arrays[0], "positions", 24);
	if (n < 0)
	{
		return NULL;
	}
	if (n > 0x7fffffff)
	{
		PyErr_SetString(PyExc_ValueError, "positions: too many particles");
		return NULL;
	}
	const ArraySpec specs[4] = { { "positions", 'd', 3 * n, 0 }, { "velocities", 'd', 3 * n, 1 },
								 { "affine", 'd', 9 * n, 1 }, { "orientations", 'd', 4 * n, 1 } };
	Py_buffer views[4];
	if (GetArrays(arrays, specs, 4, views) < 0)
	{
		return NULL;
	}
	d.count = (int)n;
	d.positions = views[0].buf;
	d.velocities = ArrayData(&views[1]);
	d.affine = ArrayData(&views[2]);
	d.orientations = ArrayData(&views[3]);
	PyThreadState* ts = Binding_Begin(obj); // 0.4 s for 2.1 million particles; Ctrl-C polled
	od_Status status = od_MpmWorld_AddParticles(world, &d);
	Binding_End(obj, ts);
	ReleaseArrays(views, 4);
	return Binding_Done(obj, status);
}

// set_wind(kind, velocity, amplitude, wavelength, octaves, persistence, drift, drag, ground, ref_height,
//          exponent, seed)
static PyObject* Mpm_set_wind(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	od_MpmWindDef d = od_DefaultMpmWindDef();
	int kind;
	unsigned int seed;
	if (!world ||
		!PyArg_ParseTuple(args, "i(ddd)ddid(dd)ddddI", &kind, &d.velocity[0], &d.velocity[1], &d.velocity[2],
						  &d.amplitude, &d.wavelength, &d.octaves, &d.persistence, &d.drift[0], &d.drift[1], &d.drag,
						  &d.ground, &d.refHeight, &d.exponent, &seed))
	{
		return NULL;
	}
	d.kind = (od_MpmWindKind)kind;
	d.seed = seed;
	return Binding_Done(obj, od_MpmWorld_SetWind(world, &d));
}

// add_collider(shape, contact, friction, half_extents, vertices|None, triangles|None, rotation, translation)
static PyObject* Mpm_add_collider(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	od_MpmColliderDef d = od_DefaultMpmColliderDef();
	int shape, contact;
	PyObject *verts, *tris, *rot;
	if (!world ||
		!PyArg_ParseTuple(args, "iid(ddd)OOO(ddd)", &shape, &contact, &d.friction, &d.halfExtents[0],
						  &d.halfExtents[1], &d.halfExtents[2], &verts, &tris, &rot, &d.translation[0],
						  &d.translation[1], &d.translation[2]))
	{
		return NULL;
	}
	d.shape = (od_MpmShape)shape;
	d.contact = (od_MpmContact)contact;
	Py_ssize_t nv = verts == Py_None ? 0 : ItemCount(verts, "vertices", 24);
	Py_ssize_t nt = tris == Py_None ? 0 : ItemCount(tris, "triangles", 12);
	if (nv < 0 || nt < 0)
	{
		return NULL;
	}
	Py_buffer rv, vv, tv;
	if (GetArray(rot, "rotation", 'd', 9, 0, &rv) < 0)
	{
		return NULL;
	}
	memcpy(d.rotation, rv.buf, sizeof d.rotation);
	PyBuffer_Release(&rv);
	if (GetOptionalArray(verts, "vertices", 'd', 3 * nv, &vv) < 0)
	{
		return NULL;
	}
	if (GetOptionalArray(tris, "triangles", 'i', 3 * nt, &tv) < 0)
	{
		ReleaseArray(&vv);
		return NULL;
	}
	d.vertexCount = (int)nv;
	d.vertices = ArrayData(&vv);
	d.triangleCount = (int)nt;
	d.triangles = ArrayData(&tv);
	int id = -1;
	// A mesh's distance samples take a moment; no other call meanwhile: the collider array may move.
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = od_MpmWorld_AddCollider(world, &d, &id);
	Binding_End(obj, ts);
	ReleaseArray(&vv);
	ReleaseArray(&tv);
	return Binding_Id(obj, status, id);
}

// move_collider(id, rotation (9 float64), translation)
static PyObject* Mpm_move_collider(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	int id;
	PyObject* rot;
	double t[3];
	if (!world || !PyArg_ParseTuple(args, "iO(ddd)", &id, &rot, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	Py_buffer rv;
	if (GetArray(rot, "rotation", 'd', 9, 0, &rv) < 0)
	{
		return NULL;
	}
	od_Status status = od_MpmWorld_MoveCollider(world, id, rv.buf, t);
	PyBuffer_Release(&rv);
	return Binding_Done(obj, status);
}

// Runs Step (substep = 0) or Substep (substep = 1) with the GIL released.
static PyObject* MpmAdvance(PyObject* obj, PyObject* args, int substep)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	double duration;
	if (!world || !PyArg_ParseTuple(args, "d", &duration))
	{
		return NULL;
	}
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = substep ? od_MpmWorld_Substep(world, duration) : od_MpmWorld_Step(world, duration);
	Binding_End(obj, ts);
	return Binding_Done(obj, status);
}

static PyObject* Mpm_step(PyObject* obj, PyObject* args)
{
	return MpmAdvance(obj, args, 0);
}

static PyObject* Mpm_substep(PyObject* obj, PyObject* args)
{
	return MpmAdvance(obj, args, 1);
}

static PyObject* Mpm_update_orientations(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_MpmWorld* world = Mpm_Enter(obj);
	if (!world)
	{
		return NULL;
	}
	PyThreadState* ts = Binding_Begin(obj); // 0.3 s for 2.1 million particles; Ctrl-C polled
	od_Status status = od_MpmWorld_UpdateOrientations(world);
	Binding_End(obj, ts);
	return Binding_Done(obj, status);
}

static const char* const MpmFieldNames[] = { "positions", "velocities", "orientations", "rotations",
											 "deformation", "affine",	  "plastic_j" };

// read(name, out): copies a field (float64, n * width) into a writable buffer.
static PyObject* Mpm_read(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	const char* name;
	PyObject* out;
	if (!world || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	for (int f = 0; f <= OD_MPM_PLASTIC_J; ++f)
	{
		if (strcmp(name, MpmFieldNames[f]) == 0)
		{
			Py_ssize_t count = (Py_ssize_t)od_MpmFieldWidth((od_MpmField)f) * od_MpmWorld_GetParticleCount(world);
			Py_buffer view;
			if (GetArray(out, "out", 'd', count, 1, &view) < 0)
			{
				return NULL;
			}
			od_MpmWorld_Read(world, (od_MpmField)f, view.buf);
			PyBuffer_Release(&view);
			Py_RETURN_NONE;
		}
	}
	PyErr_Format(PyExc_ValueError, "unknown MPM field '%s'", name);
	return NULL;
}

static PyObject* Mpm_stats(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_MpmWorld* world = Mpm_Enter(obj);
	if (!world)
	{
		return NULL;
	}
	od_MpmStats s = od_MpmWorld_GetStats(world);
	return Py_BuildValue("{sLsisdsdsisd}", "substeps", s.substeps, "last_substeps", s.lastSubsteps, "time", s.time,
						 "last_dt", s.lastDt, "active_blocks", s.activeBlocks, "max_speed", s.maxSpeed);
}

// save_state() -> bytes; load_state(bytes): the world's state for a checkpoint (od_MpmWorld_SaveState).
static PyObject* Mpm_save_state(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_MpmWorld* world = Mpm_Enter(obj);
	PyObject* out = world ? PyBytes_FromStringAndSize(NULL, (Py_ssize_t)od_MpmWorld_StateSize(world)) : NULL;
	if (!out)
	{
		return NULL;
	}
	char* bytes = PyBytes_AsString(out);
	PyThreadState* ts = Binding_Begin(obj); // 0.3 s for 2.1 million particles; Ctrl-C polled
	od_Status status = od_MpmWorld_SaveState(world, bytes);
	Binding_End(obj, ts);
	if (status != OD_OK)
	{
		Py_DECREF(out);
		return Binding_Done(obj, status);
	}
	return out;
}

static PyObject* Mpm_load_state(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	PyObject* data;
	char* bytes;
	Py_ssize_t size;
	if (!world || !PyArg_ParseTuple(args, "O!", &PyBytes_Type, &data) || PyBytes_AsStringAndSize(data, &bytes, &size) < 0)
	{
		return NULL;
	}
	return Binding_Done(obj, od_MpmWorld_LoadState(world, bytes, (size_t)size));
}

static PyObject* Mpm_get_n_particles(PyObject* obj, void* closure)
{
	(void)closure;
	od_MpmWorld* world = Mpm_Enter(obj);
	return world ? PyLong_FromLong(od_MpmWorld_GetParticleCount(world)) : NULL;
}

static PyGetSetDef Mpm_getset[] = {
	{ "n_particles", Mpm_get_n_particles, NULL, "number of particles", NULL },
	{ NULL, NULL, NULL, NULL, NULL },
};

// force_field(op, ...): the force fields (Binding_Field)
static PyObject* Mpm_force_field(PyObject* obj, PyObject* args)
{
	od_MpmWorld* world = Mpm_Enter(obj);
	return world ? Binding_Field(obj, od_MpmWorld_GetForceFields(world), args) : NULL;
}

static PyMethodDef Mpm_methods[] = {
	{ "add_particles", Mpm_add_particles, METH_VARARGS, NULL },
	{ "set_wind", Mpm_set_wind, METH_VARARGS, NULL },
	{ "add_collider", Mpm_add_collider, METH_VARARGS, NULL },
	{ "move_collider", Mpm_move_collider, METH_VARARGS, NULL },
	{ "force_field", Mpm_force_field, METH_VARARGS, "force_field(op, ...): add, move, remove or count" },
	{ "step", Mpm_step, METH_VARARGS, NULL },
	{ "substep", Mpm_substep, METH_VARARGS, NULL },
	{ "update_orientations", Mpm_update_orientations, METH_NOARGS, NULL },
	{ "read", Mpm_read, METH_VARARGS, NULL },
	{ "stats", Mpm_stats, METH_NOARGS, NULL },
	{ "save_state", Mpm_save_state, METH_NOARGS, NULL },
	{ "load_state", Mpm_load_state, METH_VARARGS, NULL },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Mpm_slots[] = {
	{ Py_tp_doc, "MLS-MPM world with tumbling particles (C core)." },
	{ Py_tp_new, Mpm_new },
	{ Py_tp_dealloc, Mpm_dealloc },
	{ Py_tp_methods, Mpm_methods },
	{ Py_tp_getset, Mpm_getset },
	{ 0, NULL },
};

PyType_Spec Mpm_Spec = {
	.name = "opdeform._core.MpmWorld",
	.basicsize = sizeof(MpmObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Mpm_slots,
};
