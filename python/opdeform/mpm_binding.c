// opdeform._core.MpmWorld: the thin binding of the MPM world (csrc/include/opdeform/mpm.h).
//
// Arguments arrive already checked and converted by opdeform/mpm.py: C-contiguous float64/int32 buffers
// and plain numbers. This file only checks buffer sizes, maps status codes to exceptions and releases
// the GIL around the steps (a busy flag refuses other calls on the same world meanwhile).
#include "binding.h"

#include "opdeform/mpm.h"

#include <string.h>

typedef struct
{
	PyObject_HEAD od_MpmWorld* world;
	int busy;
} MpmObject;

static PyObject* MpmRaise(PyObject* obj, od_Status status)
{
	return RaiseStatus(PyType_GetModule(Py_TYPE(obj)), status);
}

static int MpmEnter(MpmObject* self)
{
	if (self->busy)
	{
		PyErr_SetString(PyExc_RuntimeError, "the MPM world is being stepped by another thread");
		return -1;
	}
	return 0;
}

static PyObject* MpmDone(PyObject* obj, od_Status status)
{
	if (status != OD_OK)
	{
		return MpmRaise(obj, status);
	}
	Py_RETURN_NONE;
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
	PyTypeObject* type = Py_TYPE(obj);
	od_MpmWorld_Destroy(((MpmObject*)obj)->world);
	freefunc tp_free = (freefunc)PyType_GetSlot(type, Py_tp_free);
	tp_free(obj);
	Py_DECREF(type);
}

// add_particles(positions, velocities|None, affine|None, orientations|None, particle_volume,
//               (kind, density, young, poisson, critical_compression, critical_stretch, hardening))
static PyObject* Mpm_add_particles(PyObject* obj, PyObject* args)
{
	MpmObject* self = (MpmObject*)obj;
	PyObject *pos, *vel, *aff, *quat;
	od_MpmParticlesDef d = od_DefaultMpmParticlesDef();
	od_MpmMaterial* m = &d.material;
	int kind;
	if (MpmEnter(self) < 0 ||
		!PyArg_ParseTuple(args, "OOOOd(idddddd)", &pos, &vel, &aff, &quat, &d.particleVolume, &kind, &m->density,
						  &m->youngModulus, &m->poissonRatio, &m->criticalCompression, &m->criticalStretch,
						  &m->hardening))
	{
		return NULL;
	}
	m->kind = (od_MpmMaterialKind)kind;
	Py_ssize_t n = ItemCount(pos, "positions", 24);
	if (n < 0)
	{
		return NULL;
	}
	if (n > 0x7fffffff)
	{
		PyErr_SetString(PyExc_ValueError, "positions: too many particles");
		return NULL;
	}
	Py_buffer views[4];
	memset(views, 0, sizeof views);
	if (GetArray(pos, "positions", 'd', 3 * n, 0, &views[0]) < 0 ||
		GetOptionalArray(vel, "velocities", 'd', 3 * n, &views[1]) < 0 ||
		GetOptionalArray(aff, "affine", 'd', 9 * n, &views[2]) < 0 ||
		GetOptionalArray(quat, "orientations", 'd', 4 * n, &views[3]) < 0)
	{
		for (int k = 0; k < 4; ++k)
		{
			ReleaseArray(&views[k]);
		}
		return NULL;
	}
	d.count = (int)n;
	d.positions = views[0].buf;
	d.velocities = views[1].obj ? views[1].buf : NULL;
	d.affine = views[2].obj ? views[2].buf : NULL;
	d.orientations = views[3].obj ? views[3].buf : NULL;
	od_Status status = od_MpmWorld_AddParticles(self->world, &d);
	for (int k = 0; k < 4; ++k)
	{
		ReleaseArray(&views[k]);
	}
	return MpmDone(obj, status);
}

// set_wind(kind, velocity, amplitude, wavelength, octaves, persistence, drift, drag, ground, ref_height,
//          exponent, seed)
static PyObject* Mpm_set_wind(PyObject* obj, PyObject* args)
{
	MpmObject* self = (MpmObject*)obj;
	od_MpmWindDef d = od_DefaultMpmWindDef();
	int kind;
	unsigned int seed;
	if (MpmEnter(self) < 0 ||
		!PyArg_ParseTuple(args, "i(ddd)ddid(dd)ddddI", &kind, &d.velocity[0], &d.velocity[1], &d.velocity[2],
						  &d.amplitude, &d.wavelength, &d.octaves, &d.persistence, &d.drift[0], &d.drift[1], &d.drag,
						  &d.ground, &d.refHeight, &d.exponent, &seed))
	{
		return NULL;
	}
	d.kind = (od_MpmWindKind)kind;
	d.seed = seed;
	return MpmDone(obj, od_MpmWorld_SetWind(self->world, &d));
}

// add_collider(shape, contact, friction, half_extents, vertices|None, triangles|None, rotation, translation)
static PyObject* Mpm_add_collider(PyObject* obj, PyObject* args)
{
	MpmObject* self = (MpmObject*)obj;
	od_MpmColliderDef d = od_DefaultMpmColliderDef();
	int shape, contact;
	PyObject *verts, *tris, *rot;
	if (MpmEnter(self) < 0 ||
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
	d.vertices = vv.obj ? vv.buf : NULL;
	d.triangleCount = (int)nt;
	d.triangles = tv.obj ? tv.buf : NULL;
	int id = -1;
	self->busy = 1; // other threads must not step (or add) meanwhile: the collider array may move
	PyThreadState* ts = PyEval_SaveThread(); // a mesh's distance samples take a moment
	od_Status status = od_MpmWorld_AddCollider(self->world, &d, &id);
	PyEval_RestoreThread(ts);
	self->busy = 0;
	ReleaseArray(&vv);
	ReleaseArray(&tv);
	return status == OD_OK ? PyLong_FromLong(id) : MpmRaise(obj, status);
}

// move_collider(id, rotation (9 float64), translation)
static PyObject* Mpm_move_collider(PyObject* obj, PyObject* args)
{
	MpmObject* self = (MpmObject*)obj;
	int id;
	PyObject* rot;
	double t[3];
	if (MpmEnter(self) < 0 || !PyArg_ParseTuple(args, "iO(ddd)", &id, &rot, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	Py_buffer rv;
	if (GetArray(rot, "rotation", 'd', 9, 0, &rv) < 0)
	{
		return NULL;
	}
	od_Status status = od_MpmWorld_MoveCollider(self->world, id, rv.buf, t);
	PyBuffer_Release(&rv);
	return MpmDone(obj, status);
}

// Runs Step (substep = 0) or Substep (substep = 1) with the GIL released.
static PyObject* MpmAdvance(PyObject* obj, PyObject* args, int substep)
{
	MpmObject* self = (MpmObject*)obj;
	double duration;
	if (MpmEnter(self) < 0 || !PyArg_ParseTuple(args, "d", &duration))
	{
		return NULL;
	}
	self->busy = 1;
	PyThreadState* ts = PyEval_SaveThread();
	od_Status status =
		substep ? od_MpmWorld_Substep(self->world, duration) : od_MpmWorld_Step(self->world, duration);
	PyEval_RestoreThread(ts);
	self->busy = 0;
	return MpmDone(obj, status);
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
	MpmObject* self = (MpmObject*)obj;
	if (MpmEnter(self) < 0)
	{
		return NULL;
	}
	od_MpmWorld_UpdateOrientations(self->world);
	Py_RETURN_NONE;
}

static const char* const MpmFieldNames[] = { "positions", "velocities", "orientations", "rotations",
											 "deformation", "affine",	  "plastic_j" };

// read(name, out): copies a field (float64, n * width) into a writable buffer.
static PyObject* Mpm_read(PyObject* obj, PyObject* args)
{
	MpmObject* self = (MpmObject*)obj;
	const char* name;
	PyObject* out;
	if (MpmEnter(self) < 0 || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	for (int f = 0; f <= OD_MPM_PLASTIC_J; ++f)
	{
		if (strcmp(name, MpmFieldNames[f]) == 0)
		{
			Py_ssize_t count = (Py_ssize_t)od_MpmFieldWidth((od_MpmField)f) * od_MpmWorld_GetParticleCount(self->world);
			Py_buffer view;
			if (GetArray(out, "out", 'd', count, 1, &view) < 0)
			{
				return NULL;
			}
			od_MpmWorld_Read(self->world, (od_MpmField)f, view.buf);
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
	od_MpmStats s = od_MpmWorld_GetStats(((MpmObject*)obj)->world);
	return Py_BuildValue("{sLsisdsdsisd}", "substeps", s.substeps, "last_substeps", s.lastSubsteps, "time", s.time,
						 "last_dt", s.lastDt, "active_blocks", s.activeBlocks, "max_speed", s.maxSpeed);
}

static PyObject* Mpm_get_n_particles(PyObject* obj, void* closure)
{
	(void)closure;
	return PyLong_FromLong(od_MpmWorld_GetParticleCount(((MpmObject*)obj)->world));
}

static PyGetSetDef Mpm_getset[] = {
	{ "n_particles", Mpm_get_n_particles, NULL, "number of particles", NULL },
	{ NULL, NULL, NULL, NULL, NULL },
};

static PyMethodDef Mpm_methods[] = {
	{ "add_particles", Mpm_add_particles, METH_VARARGS, NULL },
	{ "set_wind", Mpm_set_wind, METH_VARARGS, NULL },
	{ "add_collider", Mpm_add_collider, METH_VARARGS, NULL },
	{ "move_collider", Mpm_move_collider, METH_VARARGS, NULL },
	{ "step", Mpm_step, METH_VARARGS, NULL },
	{ "substep", Mpm_substep, METH_VARARGS, NULL },
	{ "update_orientations", Mpm_update_orientations, METH_NOARGS, NULL },
	{ "read", Mpm_read, METH_VARARGS, NULL },
	{ "stats", Mpm_stats, METH_NOARGS, NULL },
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

static PyType_Spec Mpm_spec = {
	.name = "opdeform._core.MpmWorld",
	.basicsize = sizeof(MpmObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Mpm_slots,
};

int Binding_AddMpm(PyObject* module)
{
	PyObject* type = PyType_FromModuleAndSpec(module, &Mpm_spec, NULL);
	if (!type)
	{
		return -1;
	}
	int rc = PyModule_AddObjectRef(module, "MpmWorld", type);
	Py_DECREF(type);
	return rc;
}
