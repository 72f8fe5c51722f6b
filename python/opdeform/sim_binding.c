// opdeform._core.Simulation: ARAP dynamics of a graph (csrc/include/opdeform/opdeform.h).
//
// Arguments arrive converted by opdeform/simulation.py: plain numbers, tuples and C-contiguous buffers. The
// GIL is released around step and solve_static; meanwhile the busy guard refuses every call on the object.
#include "graph_binding.h"
#include "sim_binding.h"

#include "opdeform/colliders.h"

#include <limits.h>
#include <stdbool.h>
#include <string.h>

typedef struct
{
	GuardedObject head;
	od_Sim* sim;
	PyObject* graph;  // keeps the od_Graph alive
	Py_ssize_t n;     // particles
	Py_ssize_t links; // the graph's edges (links)
	int tracing;      // whether set_energy_trace is on (the core has no getter)
} SimObject;

// The od_Sim of obj, or NULL with RuntimeError while a call on another thread runs.
static od_Sim* Sim_Enter(PyObject* obj)
{
	return Binding_Enter(obj) < 0 ? NULL : ((SimObject*)obj)->sim;
}

// Simulation(graph, stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sim_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "graph", "stiffness", "density", "dt", "iterations", "gravity", "damping",
								"skin_neighbors", NULL };
	PyObject* graphObj;
	od_SimDef def = od_DefaultSimDef();
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "Od|ddi(ddd)di", keywords, &graphObj, &def.stiffness,
									 &def.density, &def.dt, &def.iterations, &def.gravity[0], &def.gravity[1],
									 &def.gravity[2], &def.damping, &def.skinNeighbors))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	const od_Graph* graph = Graph_FromObject(module, graphObj);
	if (!graph)
	{
		return NULL;
	}
	od_Sim* sim = NULL;
	od_Status status = od_Sim_Create(graph, &def, &sim);
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
	self->graph = Py_NewRef(graphObj);
	self->n = od_Graph_GetParticleCount(graph);
	self->links = od_Graph_GetEdgeCount(graph);
	return (PyObject*)self;
}

static void Sim_dealloc(PyObject* obj)
{
	SimObject* self = (SimObject*)obj;
	od_Sim_Destroy(self->sim);
	Py_XDECREF(self->graph);
	Binding_Free(obj);
}

// add_position_constraint((x,y,z), target or None, weight) -> id
static PyObject* Sim_add_position_constraint(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	double p[3], t[3], weight;
	PyObject* target;
	int given;
	if (!sim || !PyArg_ParseTuple(args, "(ddd)Od", &p[0], &p[1], &p[2], &target, &weight) ||
		GetOptionalPoint(target, t, &given) < 0)
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_Sim_AddPositionConstraint(sim, p, given ? t : NULL, weight, &id);
	return Binding_Id(obj, status, id);
}

// add_direction_constraint((x,y,z), (dx,dy,dz), target or None, weight) -> id
static PyObject* Sim_add_direction_constraint(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	double p[3], d[3], t[3], weight;
	PyObject* target;
	int given;
	if (!sim ||
		!PyArg_ParseTuple(args, "(ddd)(ddd)Od", &p[0], &p[1], &p[2], &d[0], &d[1], &d[2], &target, &weight) ||
		GetOptionalPoint(target, t, &given) < 0)
	{
		return NULL;
	}
	int id = -1;
	od_Status status = od_Sim_AddDirectionConstraint(sim, p, d, given ? t : NULL, weight, &id);
	return Binding_Id(obj, status, id);
}

static PyObject* Sim_set_constraint_target(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	double t[3];
	if (!sim || !PyArg_ParseTuple(args, "i(ddd)", &id, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetConstraintTarget(sim, id, t));
}

static PyObject* Sim_constraint_target(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	double t[3];
	if (!sim || !PyArg_ParseTuple(args, "i", &id))
	{
		return NULL;
	}
	od_Status status = od_Sim_GetConstraintTarget(sim, id, t);
	return status == OD_OK ? Py_BuildValue("(ddd)", t[0], t[1], t[2]) : Binding_Done(obj, status);
}

static PyObject* Sim_restore_constraint_target(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	double t[3];
	if (!sim || !PyArg_ParseTuple(args, "i(ddd)", &id, &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_RestoreConstraintTarget(sim, id, t));
}

static PyObject* Sim_set_constraint_weight(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	double w;
	if (!sim || !PyArg_ParseTuple(args, "id", &id, &w))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetConstraintWeight(sim, id, w));
}

static PyObject* Sim_remove_constraint(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	if (!sim || !PyArg_ParseTuple(args, "i", &id))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_RemoveConstraint(sim, id));
}

static PyObject* Sim_constraint_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyLong_FromLong(od_Sim_GetConstraintCount(sim)) : NULL;
}

static PyObject* Sim_set_floor(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	double height, friction;
	if (!sim || !PyArg_ParseTuple(args, "dd", &height, &friction))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetFloor(sim, height, friction));
}

// A setter of one optional value per particle (None: cleared): its argument named `name`.
static PyObject* Sim_SetPerParticle(PyObject* obj, PyObject* args, const char* name,
									od_Status (*set)(od_Sim*, const double*))
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* arg;
	Py_buffer view;
	if (!sim || !PyArg_ParseTuple(args, "O", &arg) || GetOptionalArray(arg, name, 'd', ((SimObject*)obj)->n, &view) < 0)
	{
		return NULL;
	}
	od_Status status = set(sim, ArrayData(&view));
	ReleaseArray(&view);
	return Binding_Done(obj, status);
}

// set_goal_frequencies(frequencies or None): n values in Hz
static PyObject* Sim_set_goal_frequencies(PyObject* obj, PyObject* args)
{
	return Sim_SetPerParticle(obj, args, "frequencies", od_Sim_SetGoalFrequencies);
}

// set_stiffness_scale(scale or None): n values > 0
static PyObject* Sim_set_stiffness_scale(PyObject* obj, PyObject* args)
{
	return Sim_SetPerParticle(obj, args, "scale", od_Sim_SetStiffnessScale);
}

// set_link_softness(softness or None): n values in (0, 1]
static PyObject* Sim_set_link_softness(PyObject* obj, PyObject* args)
{
	return Sim_SetPerParticle(obj, args, "softness", od_Sim_SetLinkSoftness);
}

// set_stretch_limit(limit, gradient or None): limit 0 off, else > 1; one gradient >= 0 per link
static PyObject* Sim_set_stretch_limit(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	double limit;
	PyObject* arg;
	Py_buffer view;
	if (!sim || !PyArg_ParseTuple(args, "dO", &limit, &arg))
	{
		return NULL;
	}
	if (GetOptionalArray(arg, "gradient", 'd', ((SimObject*)obj)->links, &view) < 0)
	{
		return NULL;
	}
	od_Status status = od_Sim_SetStretchLimit(sim, limit, ArrayData(&view));
	ReleaseArray(&view);
	return Binding_Done(obj, status);
}

static PyObject* Sim_stretch_limit(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyFloat_FromDouble(od_Sim_GetStretchLimit(sim)) : NULL;
}

// set_goals(positions, rotations or None)
static PyObject* Sim_set_goals(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2];
	if (!sim || !PyArg_ParseTuple(args, "OO", &objs[0], &objs[1]))
	{
		return NULL;
	}
	Py_ssize_t n = ((SimObject*)obj)->n;
	const ArraySpec specs[2] = { { "positions", 'd', 3 * n, 0 }, { "rotations", 'd', 9 * n, 1 } };
	Py_buffer views[2];
	if (GetArrays(objs, specs, 2, views) < 0)
	{
		return NULL;
	}
	od_Status status = od_Sim_SetGoals(sim, views[0].buf, ArrayData(&views[1]));
	ReleaseArrays(views, 2);
	return Binding_Done(obj, status);
}

// set_goal_rest(enabled)
static PyObject* Sim_set_goal_rest(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int enabled;
	if (!sim || !PyArg_ParseTuple(args, "p", &enabled))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetGoalRest(sim, enabled != 0));
}

static PyObject* Sim_goal_rest(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyBool_FromLong(od_Sim_GetGoalRest(sim)) : NULL;
}

// set_particle_damping(damping or None): n values in [0, 1]
static PyObject* Sim_set_particle_damping(PyObject* obj, PyObject* args)
{
	return Sim_SetPerParticle(obj, args, "damping", od_Sim_SetParticleDamping);
}

// The views of goal motion's two arrays (n*3 doubles each) of a getter (out: written into) or a restore: 0; or
// -1 with an exception and nothing held.
static int Sim_GoalMotionViews(PyObject* obj, PyObject* const objs[2], int out, Py_buffer views[2])
{
	Py_ssize_t n = ((SimObject*)obj)->n;
	const ArraySpec specs[2] = { { "velocities", 'd', 3 * n, 0 }, { "angular_velocities", 'd', 3 * n, 0 } };
	return out ? GetOutArrays(objs, specs, 2, views) : GetArrays(objs, specs, 2, views);
}

// The same for the surface forces' (n*3 doubles, n int32).
static int Sim_SurfaceForceViews(PyObject* obj, PyObject* const objs[2], int out, Py_buffer views[2])
{
	Py_ssize_t n = ((SimObject*)obj)->n;
	const ArraySpec specs[2] = { { "forces", 'd', 3 * n, 0 }, { "surfaces", 'i', n, 0 } };
	return out ? GetOutArrays(objs, specs, 2, views) : GetArrays(objs, specs, 2, views);
}

// goal_motion(velocities_out, angular_velocities_out) -> steps since the last set_goals (-1: none)
static PyObject* Sim_goal_motion(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2];
	Py_buffer views[2];
	if (!sim || !PyArg_ParseTuple(args, "OO", &objs[0], &objs[1]) ||
		Sim_GoalMotionViews(obj, objs, 1, views) < 0)
	{
		return NULL;
	}
	int steps = 0;
	od_Status status = od_Sim_GetGoalMotion(sim, views[0].buf, views[1].buf, &steps);
	ReleaseArrays(views, 2);
	return Binding_Id(obj, status, steps);
}

// restore_goal_motion(velocities, angular_velocities, steps)
static PyObject* Sim_restore_goal_motion(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2];
	Py_buffer views[2];
	int steps;
	if (!sim || !PyArg_ParseTuple(args, "OOi", &objs[0], &objs[1], &steps) ||
		Sim_GoalMotionViews(obj, objs, 0, views) < 0)
	{
		return NULL;
	}
	od_Status status = od_Sim_RestoreGoalMotion(sim, views[0].buf, views[1].buf, steps);
	ReleaseArrays(views, 2);
	return Binding_Done(obj, status);
}

// surface_forces(forces_out, surfaces_out): the floor's and colliders' normal forces carried to the next step
// (od_Sim_GetSurfaceForces: n*3 doubles, n int32)
static PyObject* Sim_surface_forces(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2];
	Py_buffer views[2];
	if (!sim || !PyArg_ParseTuple(args, "OO", &objs[0], &objs[1]) ||
		Sim_SurfaceForceViews(obj, objs, 1, views) < 0)
	{
		return NULL;
	}
	od_Sim_GetSurfaceForces(sim, views[0].buf, views[1].buf);
	ReleaseArrays(views, 2);
	Py_RETURN_NONE;
}

// restore_surface_forces(forces, surfaces)
static PyObject* Sim_restore_surface_forces(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2];
	Py_buffer views[2];
	if (!sim || !PyArg_ParseTuple(args, "OO", &objs[0], &objs[1]) ||
		Sim_SurfaceForceViews(obj, objs, 0, views) < 0)
	{
		return NULL;
	}
	od_Status status = od_Sim_RestoreSurfaceForces(sim, views[0].buf, views[1].buf);
	ReleaseArrays(views, 2);
	return Binding_Done(obj, status);
}

static PyObject* Sim_clear_floor(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	if (!sim)
	{
		return NULL;
	}
	od_Sim_ClearFloor(sim);
	Py_RETURN_NONE;
}

// add_collider(shape, half_extents, radius, half_length, vertices or None, triangles or None, resolution,
// friction, thickness, rotation (9 values), translation) -> id
static PyObject* Sim_add_collider(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	od_ColliderDef d = od_DefaultColliderDef();
	int shape;
	PyObject* objs[3];
	double* h = d.halfExtents;
	double* t = d.translation;
	if (!sim || !PyArg_ParseTuple(args, "i(ddd)ddOOiddO(ddd)", &shape, &h[0], &h[1], &h[2], &d.radius,
								  &d.halfLength, &objs[0], &objs[1], &d.resolution, &d.friction, &d.thickness,
								  &objs[2], &t[0], &t[1], &t[2]))
	{
		return NULL;
	}
	Py_ssize_t nv = objs[0] == Py_None ? 0 : ItemCount(objs[0], "vertices", 3 * sizeof(double));
	Py_ssize_t nt = objs[1] == Py_None ? 0 : ItemCount(objs[1], "triangles", 3 * sizeof(int));
	const ArraySpec specs[3] = { { "vertices", 'd', 3 * nv, 1 }, { "triangles", 'i', 3 * nt, 1 },
								 { "rotation", 'd', 9, 0 } };
	Py_buffer views[3];
	if (nv < 0 || nt < 0 || nv > INT_MAX || nt > INT_MAX || GetArrays(objs, specs, 3, views) < 0)
	{
		return nv > INT_MAX || nt > INT_MAX ? PyErr_Format(PyExc_ValueError, "vertices: too many") : NULL;
	}
	d.shape = (od_ColliderShape)shape;
	d.vertexCount = (int)nv;
	d.vertices = ArrayData(&views[0]);
	d.triangleCount = (int)nt;
	d.triangles = ArrayData(&views[1]);
	memcpy(d.rotation, views[2].buf, sizeof d.rotation);
	int id = -1;
	PyThreadState* ts = Binding_Begin(obj); // a mesh's distance samples: seconds for a million triangles
	od_Status status = od_Sim_AddCollider(sim, &d, &id);
	Binding_End(obj, ts);
	ReleaseArrays(views, 3);
	return Binding_Id(obj, status, id);
}

// move_collider(id, rotation (9 values), translation)
static PyObject* Sim_move_collider(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	PyObject* rotation;
	double t[3];
	Py_buffer view;
	if (!sim || !PyArg_ParseTuple(args, "iO(ddd)", &id, &rotation, &t[0], &t[1], &t[2]) ||
		GetArray(rotation, "rotation", 'd', 9, 0, &view) < 0)
	{
		return NULL;
	}
	od_Status status = od_Sim_MoveCollider(sim, id, view.buf, t);
	ReleaseArray(&view);
	return Binding_Done(obj, status);
}

// update_collider_vertices(id, vertices)
static PyObject* Sim_update_collider_vertices(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	PyObject* vertices;
	Py_buffer view;
	if (!sim || !PyArg_ParseTuple(args, "iO", &id, &vertices))
	{
		return NULL;
	}
	Py_ssize_t nv = ItemCount(vertices, "vertices", 3 * sizeof(double));
	if (nv < 0 || nv > INT_MAX || GetArray(vertices, "vertices", 'd', 3 * nv, 0, &view) < 0)
	{
		return nv > INT_MAX ? PyErr_Format(PyExc_ValueError, "vertices: too many") : NULL;
	}
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = od_Sim_UpdateColliderVertices(sim, id, view.buf, (int)nv);
	Binding_End(obj, ts);
	ReleaseArray(&view);
	return Binding_Done(obj, status);
}

static PyObject* Sim_set_collider_contact(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	double friction, thickness;
	if (!sim || !PyArg_ParseTuple(args, "idd", &id, &friction, &thickness))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetColliderContact(sim, id, friction, thickness));
}

static PyObject* Sim_remove_collider(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	int id;
	if (!sim || !PyArg_ParseTuple(args, "i", &id))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_RemoveCollider(sim, id));
}

static PyObject* Sim_collider_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyLong_FromLong(od_Sim_GetColliderCount(sim)) : NULL;
}

// push_out(points) -> moved: points (float64, 3 per point) rewritten in place, or
// collider_distances(points, out): the signed distance of each point into out (float64, 1 per point).
static PyObject* PointQuery(PyObject* obj, PyObject* args, int push)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* objs[2] = { NULL, NULL };
	if (!sim || !PyArg_ParseTuple(args, push ? "O" : "OO", &objs[0], &objs[1]))
	{
		return NULL;
	}
	Py_ssize_t n = ItemCount(objs[0], "points", 3 * sizeof(double));
	Py_buffer views[2] = { { 0 }, { 0 } };
	if (n < 0 || n > INT_MAX || GetArray(objs[0], "points", 'd', 3 * n, push, &views[0]) < 0 ||
		(!push && GetArray(objs[1], "out", 'd', n, 1, &views[1]) < 0))
	{
		ReleaseArrays(views, 2);
		return n > INT_MAX ? PyErr_Format(PyExc_ValueError, "points: too many") : NULL;
	}
	int moved = 0;
	od_Status status = push ? od_Sim_PushOut(sim, views[0].buf, (int)n, &moved)
							: od_Sim_GetColliderDistances(sim, views[0].buf, (int)n, views[1].buf);
	ReleaseArrays(views, 2);
	return Binding_Id(obj, status, moved);
}

static PyObject* Sim_push_out(PyObject* obj, PyObject* args)
{
	return PointQuery(obj, args, 1);
}

static PyObject* Sim_collider_distances(PyObject* obj, PyObject* args)
{
	return PointQuery(obj, args, 0);
}

// set_contact_skin(points, particles, bodies): points (float64, 3 each) carried by particles (int32, 1 each);
// none: off; bodies: whether they meet the other bodies of a group too.
static PyObject* Sim_set_contact_skin(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	PyObject* arrays[2];
	int bodies;
	if (!sim || !PyArg_ParseTuple(args, "OOp", &arrays[0], &arrays[1], &bodies))
	{
		return NULL;
	}
	Py_ssize_t n = ItemCount(arrays[0], "points", 24);
	const ArraySpec specs[2] = { { "points", 'd', 3 * n, 0 }, { "particles", 'i', n, 0 } };
	Py_buffer views[2];
	if (n < 0 || n > INT_MAX / 3 || GetArrays(arrays, specs, 2, views) < 0)
	{
		return n > INT_MAX / 3 ? PyErr_Format(PyExc_ValueError, "points: too many") : NULL;
	}
	od_Status status = od_Sim_SetContactSkin(sim, views[0].buf, views[1].buf, (int)n, bodies);
	ReleaseArrays(views, 2);
	return Binding_Done(obj, status);
}

static PyObject* Sim_contact_skin_count(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyLong_FromLong(od_Sim_GetContactSkinCount(sim)) : NULL;
}

// force_field(op, ...): the force fields (Binding_Field)
static PyObject* Sim_force_field(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	return sim ? Binding_Field(obj, od_Sim_GetForceFields(sim), args) : NULL;
}

// set_self_contact(enabled, thickness, friction, exclusion_ring, exclusion_scale)
static PyObject* Sim_set_self_contact(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	od_BodyContactDef d = od_DefaultBodyContactDef();
	int enabled;
	if (!sim || !PyArg_ParseTuple(args, "pddid", &enabled, &d.thickness, &d.friction, &d.exclusionRing,
								  &d.exclusionScale))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetSelfContact(sim, enabled ? &d : NULL));
}

// self_contact() -> its settings as a dict, or None when off
static PyObject* Sim_self_contact(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	od_BodyContactDef d;
	if (!sim)
	{
		return NULL;
	}
	if (!od_Sim_GetSelfContact(sim, &d))
	{
		Py_RETURN_NONE;
	}
	return Py_BuildValue("{sdsdsisd}", "thickness", d.thickness, "friction", d.friction, "exclusion_ring",
						 d.exclusionRing, "exclusion_scale", d.exclusionScale);
}

// Runs step (static = 0) or solve_static (static = 1) with the GIL released.
static PyObject* RunSolver(PyObject* obj, PyObject* args, int isStatic)
{
	od_Sim* sim = Sim_Enter(obj);
	int count;
	if (!sim || !PyArg_ParseTuple(args, "i", &count))
	{
		return NULL;
	}
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = isStatic ? od_Sim_SolveStatic(sim, count) : od_Sim_Step(sim, count);
	Binding_End(obj, ts);
	return Binding_Done(obj, status);
}

static PyObject* Sim_step(PyObject* obj, PyObject* args)
{
	return RunSolver(obj, args, 0);
}

static PyObject* Sim_solve_static(PyObject* obj, PyObject* args)
{
	return RunSolver(obj, args, 1);
}

// set_state(positions, rotations, velocities=None, angular_velocities=None)
// set_state and restore_state(positions, rotations, velocities=None, angular_velocities=None): od_Sim_SetState
// (rotations orthonormalised) or od_Sim_RestoreState (as they are).
static PyObject* PutState(PyObject* obj, PyObject* args, int exact)
{
	od_Sim* sim = Sim_Enter(obj);
	Py_buffer v[4];
	if (!sim || GetStateArrays(args, ((SimObject*)obj)->n, v) < 0)
	{
		return NULL;
	}
	od_Status status = (exact ? od_Sim_RestoreState : od_Sim_SetState)(sim, v[0].buf, v[1].buf, ArrayData(&v[2]),
																	   ArrayData(&v[3]));
	ReleaseArrays(v, 4);
	return Binding_Done(obj, status);
}

static PyObject* Sim_set_state(PyObject* obj, PyObject* args)
{
	return PutState(obj, args, 0);
}

static PyObject* Sim_restore_state(PyObject* obj, PyObject* args)
{
	return PutState(obj, args, 1);
}

// read(name, out) -> count: "positions", "rotations", "velocities", "angular_velocities", "energy_trace",
// "stiffness_scale", "link_softness" or "particle_damping" (the last three: 0 when not set).
static PyObject* Sim_read(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	const char* name;
	PyObject* out;
	if (!sim || !PyArg_ParseTuple(args, "sO", &name, &out))
	{
		return NULL;
	}
	const double* fields[4] = { od_Sim_GetPositions(sim), od_Sim_GetRotations(sim), od_Sim_GetVelocities(sim),
								od_Sim_GetAngularVelocities(sim) };
	int index = StateArrayIndex(name), traceCount = 0;
	bool scale = strcmp(name, "stiffness_scale") == 0; // n values, or none (0) when all 1
	bool softness = strcmp(name, "link_softness") == 0; // n values, or none (0) when all 1
	bool damping = strcmp(name, "particle_damping") == 0; // n values, or none (0) when def.damping for all
	if (index < 0 && !scale && !softness && !damping && strcmp(name, "energy_trace") != 0)
	{
		PyErr_Format(PyExc_ValueError, "unknown state array '%s'", name);
		return NULL;
	}
	Py_ssize_t n = ((SimObject*)obj)->n;
	const double* data = index >= 0 ? fields[index] : od_Sim_GetEnergyTrace(sim, &traceCount);
	Py_ssize_t count = index >= 0 ? StateArrayCount(index, n) : traceCount;
	if (scale || softness || damping)
	{
		data = scale ? od_Sim_GetStiffnessScale(sim)
					 : (softness ? od_Sim_GetLinkSoftness(sim) : od_Sim_GetParticleDamping(sim));
		count = data ? n : 0;
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
	od_Sim* sim = Sim_Enter(obj);
	int count = 0;
	if (!sim)
	{
		return NULL;
	}
	od_Sim_GetEnergyTrace(sim, &count);
	return PyLong_FromLong(count);
}

static PyObject* Sim_get_trace_energy(PyObject* obj, void* closure)
{
	(void)closure;
	return Sim_Enter(obj) ? PyBool_FromLong(((SimObject*)obj)->tracing) : NULL;
}

static int Sim_set_trace_energy(PyObject* obj, PyObject* value, void* closure)
{
	(void)closure;
	od_Sim* sim = Sim_Enter(obj);
	if (sim && !value)
	{
		PyErr_SetString(PyExc_AttributeError, "trace_energy cannot be deleted");
	}
	int enabled = sim && value ? PyObject_IsTrue(value) : -1;
	if (enabled < 0)
	{
		return -1;
	}
	od_Sim_SetEnergyTrace(sim, enabled);
	((SimObject*)obj)->tracing = enabled;
	return 0;
}

static PyObject* Sim_energy(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? PyFloat_FromDouble(od_Sim_GetEnergy(sim)) : NULL;
}

static PyObject* Sim_params(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	return sim ? BINDING_DEF_DICT(od_Sim_GetDef(sim)) : NULL;
}

// set_params(stiffness, density, dt, iterations, gravity, damping, skin_neighbors)
static PyObject* Sim_set_params(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	od_SimDef d;
	if (!sim || !PyArg_ParseTuple(args, BINDING_DEF_FORMAT, BINDING_DEF_ARGS(d)))
	{
		return NULL;
	}
	return Binding_Done(obj, od_Sim_SetDef(sim, &d));
}

static PyObject* Sim_counters(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	if (!sim)
	{
		return NULL;
	}
	od_SimCounters c = od_Sim_GetCounters(sim);
	return Py_BuildValue("{sLsLsLsLsLsLsLsdsdsdsd}", "factorizations", c.factorizations, "analyses", c.analyses,
						 "solves", c.solves, "steps", c.steps, "polar_fallbacks", c.polarFallbacks, "accelerated",
						 c.accelerated, "rejected", c.rejected, "local_seconds", c.localSeconds, "global_seconds",
						 c.globalSeconds, "analyze_seconds", c.analyzeSeconds, "factor_seconds", c.factorSeconds);
}

// set_solver(accelerator: 0 none | 1 anderson | 2 chebyshev | 3 auto, window, rho, threads, factorization, tolerance,
// max_iterations)
static PyObject* Sim_set_solver(PyObject* obj, PyObject* args)
{
	od_Sim* sim = Sim_Enter(obj);
	od_SolverDef d = od_DefaultSolverDef();
	int kind;
	if (!sim || !PyArg_ParseTuple(args, "iidiidi", &kind, &d.window, &d.rho, &d.threads, &d.factorization,
								  &d.tolerance, &d.maxIterations))
	{
		return NULL;
	}
	d.accelerator = (od_AcceleratorKind)kind;
	return Binding_Done(obj, od_Sim_SetSolver(sim, &d));
}

static PyObject* Sim_solver(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	if (!sim)
	{
		return NULL;
	}
	od_SolverDef d = od_Sim_GetSolver(sim);
	return Py_BuildValue("{sisisdsisisdsi}", "accelerator", (int)d.accelerator, "window", d.window, "rho", d.rho,
						 "threads", d.threads, "factorization", d.factorization, "tolerance", d.tolerance,
						 "max_iterations", d.maxIterations);
}

static PyObject* Sim_thread_bound(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	if (!sim)
	{
		return NULL;
	}
	od_ThreadBound b = od_Sim_GetThreadBound(sim);
	return Py_BuildValue("{sisdsd}", "threads", b.threads, "local", b.local, "global", b.global);
}

static PyObject* Sim_step_report(PyObject* obj, PyObject* unused)
{
	(void)unused;
	od_Sim* sim = Sim_Enter(obj);
	if (!sim)
	{
		return NULL;
	}
	od_StepReport r = od_Sim_GetStepReport(sim);
	return Py_BuildValue("{sisisisdsi}", "steps", r.steps, "iterations", r.iterations, "most_iterations",
						 r.mostIterations, "error", r.error, "unconverged", r.unconverged);
}

static PyGetSetDef Sim_getset[] = {
	{ "trace_energy", Sim_get_trace_energy, Sim_set_trace_energy, "record the objective of every half step", NULL },
	{ NULL, NULL, NULL, NULL, NULL },
};

static PyMethodDef Sim_methods[] = {
	{ "add_position_constraint", Sim_add_position_constraint, METH_VARARGS, NULL },
	{ "add_direction_constraint", Sim_add_direction_constraint, METH_VARARGS, NULL },
	{ "set_constraint_target", Sim_set_constraint_target, METH_VARARGS, NULL },
	{ "set_constraint_weight", Sim_set_constraint_weight, METH_VARARGS, NULL },
	{ "constraint_target", Sim_constraint_target, METH_VARARGS, "constraint_target(id) -> the target as stored" },
	{ "restore_constraint_target", Sim_restore_constraint_target, METH_VARARGS,
	  "restore_constraint_target(id, target): sets a stored target back unchanged" },
	{ "remove_constraint", Sim_remove_constraint, METH_VARARGS, NULL },
	{ "constraint_count", Sim_constraint_count, METH_NOARGS, NULL },
	{ "set_floor", Sim_set_floor, METH_VARARGS, NULL },
	{ "clear_floor", Sim_clear_floor, METH_NOARGS, NULL },
	{ "set_goal_frequencies", Sim_set_goal_frequencies, METH_VARARGS, "set_goal_frequencies(frequencies or None)" },
	{ "set_goals", Sim_set_goals, METH_VARARGS, "set_goals(positions, rotations or None)" },
	{ "set_stiffness_scale", Sim_set_stiffness_scale, METH_VARARGS, "set_stiffness_scale(scale or None)" },
	{ "set_link_softness", Sim_set_link_softness, METH_VARARGS, "set_link_softness(softness or None)" },
	{ "set_stretch_limit", Sim_set_stretch_limit, METH_VARARGS, "set_stretch_limit(limit, gradient or None): limit 0 off, else > 1" },
	{ "stretch_limit", Sim_stretch_limit, METH_NOARGS, "stretch_limit() -> the stretch bound's limit (0: off)" },
	{ "set_goal_rest", Sim_set_goal_rest, METH_VARARGS, "set_goal_rest(enabled): the goals carry the rest shape" },
	{ "goal_rest", Sim_goal_rest, METH_NOARGS, "goal_rest() -> whether the goals carry the rest shape" },
	{ "goal_motion", Sim_goal_motion, METH_VARARGS, "goal_motion(velocities_out, angular_velocities_out) -> steps" },
	{ "restore_goal_motion", Sim_restore_goal_motion, METH_VARARGS,
	  "restore_goal_motion(velocities, angular_velocities, steps)" },
	{ "surface_forces", Sim_surface_forces, METH_VARARGS, "surface_forces(forces_out, surfaces_out)" },
	{ "restore_surface_forces", Sim_restore_surface_forces, METH_VARARGS, "restore_surface_forces(forces, surfaces)" },
	{ "set_particle_damping", Sim_set_particle_damping, METH_VARARGS, "set_particle_damping(damping or None)" },
	{ "add_collider", Sim_add_collider, METH_VARARGS, NULL },
	{ "move_collider", Sim_move_collider, METH_VARARGS, NULL },
	{ "update_collider_vertices", Sim_update_collider_vertices, METH_VARARGS, NULL },
	{ "set_collider_contact", Sim_set_collider_contact, METH_VARARGS, NULL },
	{ "remove_collider", Sim_remove_collider, METH_VARARGS, NULL },
	{ "collider_count", Sim_collider_count, METH_NOARGS, NULL },
	{ "set_contact_skin", Sim_set_contact_skin, METH_VARARGS, NULL },
	{ "contact_skin_count", Sim_contact_skin_count, METH_NOARGS, NULL },
	{ "push_out", Sim_push_out, METH_VARARGS, "push_out(points) -> moved: points rewritten in place" },
	{ "collider_distances", Sim_collider_distances, METH_VARARGS, "collider_distances(points, out)" },
	{ "set_self_contact", Sim_set_self_contact, METH_VARARGS, NULL },
	{ "self_contact", Sim_self_contact, METH_NOARGS, "self_contact() -> settings or None" },
	{ "force_field", Sim_force_field, METH_VARARGS, "force_field(op, ...): add, move, remove or count" },
	{ "step", Sim_step, METH_VARARGS, NULL },
	{ "solve_static", Sim_solve_static, METH_VARARGS, NULL },
	{ "set_state", Sim_set_state, METH_VARARGS, NULL },
	{ "restore_state", Sim_restore_state, METH_VARARGS, NULL },
	{ "read", Sim_read, METH_VARARGS, NULL },
	{ "trace_length", Sim_trace_length, METH_NOARGS, NULL },
	{ "energy", Sim_energy, METH_NOARGS, NULL },
	{ "params", Sim_params, METH_NOARGS, NULL },
	{ "set_params", Sim_set_params, METH_VARARGS, NULL },
	{ "counters", Sim_counters, METH_NOARGS, NULL },
	{ "step_report", Sim_step_report, METH_NOARGS, NULL },
	{ "thread_bound", Sim_thread_bound, METH_NOARGS,
	  "thread_bound() -> {threads, local, global}: the speed-up the threads' plan allows each stage at most" },
	{ "set_solver", Sim_set_solver, METH_VARARGS, NULL },
	{ "solver", Sim_solver, METH_NOARGS, NULL },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Sim_slots[] = {
	{ Py_tp_doc, "ARAP dynamics of an oriented-particle graph (C core)." },
	{ Py_tp_new, Sim_new },
	{ Py_tp_dealloc, Sim_dealloc },
	{ Py_tp_getset, Sim_getset },
	{ Py_tp_methods, Sim_methods },
	{ 0, NULL },
};

PyType_Spec Sim_Spec = {
	.name = "opdeform._core.Simulation",
	.basicsize = sizeof(SimObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Sim_slots,
};

// ---------------------------------------------------------------------------------------------------------
// opdeform._core.ContactGroup: simulations that collide with each other (od_ContactGroup). Its step releases
// the GIL with every member marked busy as well as the group.

typedef struct
{
	GuardedObject head;
	od_ContactGroup* group;
	PyObject* sims; // a tuple of the member Simulation objects, kept alive
} GroupObject;

// ContactGroup(sims (a sequence of _core.Simulation), thickness, friction, in_iterations)
static PyObject* Group_new(PyTypeObject* type, PyObject* args, PyObject* kwargs)
{
	static char* keywords[] = { "sims", "thickness", "friction", "in_iterations", NULL };
	PyObject* seq;
	od_BodyContactDef def = od_DefaultBodyContactDef();
	if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O|ddp", keywords, &seq, &def.thickness, &def.friction,
									 &def.inIterations))
	{
		return NULL;
	}
	PyObject* module = PyType_GetModule(type);
	PyObject* sims = PySequence_Tuple(seq);
	if (!sims)
	{
		return NULL;
	}
	Py_ssize_t count = PyTuple_Size(sims);
	od_Sim** list = count <= INT_MAX ? PyMem_Malloc(sizeof *list * (size_t)(count > 0 ? count : 1)) : NULL;
	int ok = list != NULL;
	for (Py_ssize_t b = 0; b < count && ok; ++b)
	{
		PyObject* item = PyTuple_GetItem(sims, b);
		ok = PyObject_TypeCheck(item, Binding_State(module)->simType);
		list[b] = ok ? ((SimObject*)item)->sim : NULL;
		if (!ok)
		{
			PyErr_Format(PyExc_TypeError, "sims[%zd] is not an opdeform Simulation", b);
		}
	}
	if (!ok)
	{
		PyMem_Free(list);
		Py_DECREF(sims);
		return list ? NULL : PyErr_NoMemory();
	}
	od_ContactGroup* group = NULL;
	od_Status status = od_ContactGroup_Create(list, (int)count, &def, &group);
	PyMem_Free(list);
	GroupObject* self = status == OD_OK ? (GroupObject*)PyType_GenericAlloc(type, 0) : NULL;
	if (!self)
	{
		od_ContactGroup_Destroy(group);
		Py_DECREF(sims);
		return status != OD_OK ? RaiseStatus(module, status) : NULL;
	}
	self->group = group;
	self->sims = sims;
	return (PyObject*)self;
}

static void Group_dealloc(PyObject* obj)
{
	GroupObject* self = (GroupObject*)obj;
	od_ContactGroup_Destroy(self->group);
	Py_XDECREF(self->sims);
	Binding_Free(obj);
}

// set_contact(thickness, friction, in_iterations=True)
static PyObject* Group_set_contact(PyObject* obj, PyObject* args)
{
	od_BodyContactDef d = od_DefaultBodyContactDef();
	if (Binding_Enter(obj) < 0 || !PyArg_ParseTuple(args, "dd|p", &d.thickness, &d.friction, &d.inIterations))
	{
		return NULL;
	}
	return Binding_Done(obj, od_ContactGroup_SetContact(((GroupObject*)obj)->group, &d));
}

// step(steps): every member marked busy (refused if one is) while the GIL is released
static PyObject* Group_step(PyObject* obj, PyObject* args)
{
	GroupObject* self = (GroupObject*)obj;
	int steps;
	Py_ssize_t count = PyTuple_Size(self->sims);
	if (Binding_Enter(obj) < 0 || !PyArg_ParseTuple(args, "i", &steps))
	{
		return NULL;
	}
	for (Py_ssize_t b = 0; b < count; ++b)
	{
		if (Binding_Enter(PyTuple_GetItem(self->sims, b)) < 0)
		{
			return NULL;
		}
	}
	for (Py_ssize_t b = 0; b < count; ++b)
	{
		((GuardedObject*)PyTuple_GetItem(self->sims, b))->busy = 1;
	}
	PyThreadState* ts = Binding_Begin(obj);
	od_Status status = od_ContactGroup_Step(self->group, steps);
	Binding_End(obj, ts);
	for (Py_ssize_t b = 0; b < count; ++b)
	{
		((GuardedObject*)PyTuple_GetItem(self->sims, b))->busy = 0;
	}
	return Binding_Done(obj, status);
}

// pair_count(): how many pairs the group keeps between steps (od_ContactGroup_GetPairCount)
static PyObject* Group_pair_count(PyObject* obj, PyObject* args)
{
	(void)args;
	if (Binding_Enter(obj) < 0)
	{
		return NULL;
	}
	return PyLong_FromLong(od_ContactGroup_GetPairCount(((GroupObject*)obj)->group));
}

// read_pairs(pairs, forces): writable int32 (pair_count * 2) and float64 (pair_count * OD_PAIR_VALUES) buffers
static PyObject* Group_read_pairs(PyObject* obj, PyObject* args)
{
	PyObject *pairs, *forces;
	if (Binding_Enter(obj) < 0 || !PyArg_ParseTuple(args, "OO", &pairs, &forces))
	{
		return NULL;
	}
	od_ContactGroup* group = ((GroupObject*)obj)->group;
	Py_ssize_t m = od_ContactGroup_GetPairCount(group);
	Py_buffer views[2] = { { 0 }, { 0 } };
	if (GetArray(pairs, "pairs", 'i', 2 * m, 1, &views[0]) < 0 || GetArray(forces, "forces", 'd', OD_PAIR_VALUES * m, 1, &views[1]) < 0)
	{
		ReleaseArrays(views, 2);
		return NULL;
	}
	od_ContactGroup_GetPairs(group, views[0].buf, views[1].buf);
	ReleaseArrays(views, 2);
	Py_RETURN_NONE;
}

// write_pairs(pairs, forces): int32 (m * 2) and float64 (m * OD_PAIR_VALUES) buffers (od_ContactGroup_SetPairs)
static PyObject* Group_write_pairs(PyObject* obj, PyObject* args)
{
	PyObject *pairs, *forces;
	if (Binding_Enter(obj) < 0 || !PyArg_ParseTuple(args, "OO", &pairs, &forces))
	{
		return NULL;
	}
	Py_ssize_t m = ItemCount(pairs, "pairs", 8);
	if (m < 0 || m > INT_MAX)
	{
		return m < 0 ? NULL : PyErr_Format(PyExc_ValueError, "pairs: too many (%zd)", m);
	}
	Py_buffer views[2] = { { 0 }, { 0 } };
	if (GetArray(pairs, "pairs", 'i', 2 * m, 0, &views[0]) < 0 || GetArray(forces, "forces", 'd', OD_PAIR_VALUES * m, 0, &views[1]) < 0)
	{
		ReleaseArrays(views, 2);
		return NULL;
	}
	od_Status status = od_ContactGroup_SetPairs(((GroupObject*)obj)->group, (int)m, views[0].buf, views[1].buf);
	ReleaseArrays(views, 2);
	return Binding_Done(obj, status);
}

static PyMethodDef Group_methods[] = {
	{ "set_contact", Group_set_contact, METH_VARARGS, "set_contact(thickness, friction)" },
	{ "step", Group_step, METH_VARARGS, "step(steps)" },
	{ "pair_count", Group_pair_count, METH_NOARGS, "pair_count()" },
	{ "read_pairs", Group_read_pairs, METH_VARARGS, "read_pairs(pairs, forces)" },
	{ "write_pairs", Group_write_pairs, METH_VARARGS, "write_pairs(pairs, forces)" },
	{ NULL, NULL, 0, NULL },
};

static PyType_Slot Group_slots[] = {
	{ Py_tp_doc, "Simulations that collide with each other (C core)." },
	{ Py_tp_new, Group_new },
	{ Py_tp_dealloc, Group_dealloc },
	{ Py_tp_methods, Group_methods },
	{ 0, NULL },
};

PyType_Spec Group_Spec = {
	.name = "opdeform._core.ContactGroup",
	.basicsize = sizeof(GroupObject),
	.flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_IMMUTABLETYPE,
	.slots = Group_slots,
};
