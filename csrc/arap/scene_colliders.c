// Scene colliders of a simulation (opdeform/colliders.h): the set, its checks and the frames over a call.
// The shapes are the shared signed distances of collide/collider.c; what contact does is contact.c's.
//
// A mesh is closed when every edge joins two triangles (inside by the parity of crossings, its winding
// irrelevant) and open otherwise (inside is behind the nearest triangle, so a face wound against its
// neighbours is refused). A mesh is sampled at `resolution` samples along its longest side: 64 by default;
// a deforming 3,744-triangle sphere re-samples in 71 ms at 64 and 32 ms at 32 (docs/contact.md, measured).
#include "scene_colliders.h"

#include "buffer.h"
#include "core.h"
#include "sim.h"

#include <math.h>
#include <string.h>

od_ColliderDef od_DefaultColliderDef(void)
{
	return (od_ColliderDef){ .shape = OD_COLLIDER_PLANE,
							 .halfExtents = { 0.5, 0.5, 0.5 },
							 .radius = 0.5,
							 .halfLength = 0.5,
							 .resolution = 64,
							 .friction = 0.5,
							 .thickness = 0.005,
							 .rotation = { 1, 0, 0, 0, 1, 0, 0, 0, 1 } };
}

static od_Status od_CheckContact(double friction, double thickness)
{
	if (!(friction >= 0.0) || !isfinite(friction))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "friction = %g must be finite and >= 0", friction);
	}
	if (!(thickness > 0.0) || !isfinite(thickness))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "thickness = %g must be finite and > 0", thickness);
	}
	return OD_OK;
}

// The shared shape of a definition (a mesh: closed or open by its edges, collide/collider.c decides).
static od_Status od_ShapeOf(const od_ColliderDef* def, od_ShapeDef* shape)
{
	*shape = (od_ShapeDef){ .vertexCount = def->vertexCount, .vertices = def->vertices,
							.triangleCount = def->triangleCount, .triangles = def->triangles,
							.resolution = def->resolution };
	const od_ShapeKind kinds[] = { OD_SHAPE_PLANE, OD_SHAPE_BOX, OD_SHAPE_SPHERE, OD_SHAPE_CAPSULE, OD_SHAPE_MESH };
	if (def->shape < OD_COLLIDER_PLANE || def->shape > OD_COLLIDER_MESH)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "shape = %d is not a collider shape", (int)def->shape);
	}
	shape->kind = kinds[def->shape];
	memcpy(shape->halfExtents, def->halfExtents, sizeof shape->halfExtents);
	if (def->shape == OD_COLLIDER_SPHERE || def->shape == OD_COLLIDER_CAPSULE)
	{
		shape->halfExtents[0] = def->radius;
		shape->halfExtents[2] = def->shape == OD_COLLIDER_CAPSULE ? def->halfLength : 0.0;
	}
	if (def->shape != OD_COLLIDER_MESH)
	{
		return OD_OK;
	}
	if (def->triangleCount < 1 || !def->triangles || def->vertexCount < 3 || !def->vertices)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "triangles: a mesh collider needs vertices and at least one face");
	}
	if (def->resolution < 8 || def->resolution > 88)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "resolution = %d must be in [8, 88]", def->resolution);
	}
	shape->detectOpen = true;
	return OD_OK;
}

static od_SimCollider* od_Find(const od_Sim* sim, int id)
{
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		if (sim->colliders.items[k].id == id)
		{
			return &sim->colliders.items[k];
		}
	}
	od_Fail(OD_ERROR_NOT_FOUND, "no collider %d", id);
	return NULL;
}

od_Status od_Sim_AddCollider(od_Sim* sim, const od_ColliderDef* def, int* id)
{
	od_ShapeDef shape;
	od_Status status = od_CheckContact(def->friction, def->thickness);
	status = status == OD_OK ? od_ShapeOf(def, &shape) : status;
	status = status == OD_OK ? od_Grow((void**)&sim->colliders.items, &sim->colliders.capacity, sim->colliders.count + 1,
									   sizeof(od_SimCollider), "colliders") : status;
	if (status != OD_OK)
	{
		return status;
	}
	od_SimCollider c = { .id = sim->colliders.nextId, .friction = def->friction, .thickness = def->thickness };
	if (def->shape == OD_COLLIDER_MESH)
	{
		c.triangles = od_Alloc(sizeof(int) * 3 * (size_t)def->triangleCount);
		if (!c.triangles)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for a mesh collider");
		}
		memcpy(c.triangles, def->triangles, sizeof(int) * 3 * (size_t)def->triangleCount);
		c.vertexCount = def->vertexCount;
		c.triangleCount = def->triangleCount;
	}
	status = od_Collider_Init(&c.body, &shape, def->rotation, def->translation);
	if (status != OD_OK)
	{
		od_Free(c.triangles);
		return status;
	}
	sim->colliders.items[sim->colliders.count++] = c;
	*id = sim->colliders.nextId++;
	return OD_OK;
}

od_Status od_Sim_MoveCollider(od_Sim* sim, int id, const double rotation[9], const double translation[3])
{
	od_SimCollider* c = od_Find(sim, id);
	return c ? od_Collider_SetTarget(&c->body, rotation, translation) : OD_ERROR_NOT_FOUND;
}

od_Status od_Sim_UpdateColliderVertices(od_Sim* sim, int id, const double* vertices, int vertexCount)
{
	od_SimCollider* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	if (!c->triangles || !vertices || vertexCount != c->vertexCount)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "vertices: collider %d takes %d vertices (a mesh's), got %d", id,
					   c->vertexCount, vertexCount);
	}
	return od_Collider_SetVertices(&c->body, vertices, c->vertexCount, c->triangles, c->triangleCount);
}

od_Status od_Sim_SetColliderContact(od_Sim* sim, int id, double friction, double thickness)
{
	od_SimCollider* c = od_Find(sim, id);
	od_Status status = c ? od_CheckContact(friction, thickness) : OD_ERROR_NOT_FOUND;
	if (status == OD_OK)
	{
		c->friction = friction;
		c->thickness = thickness;
	}
	return status;
}

od_Status od_Sim_RemoveCollider(od_Sim* sim, int id)
{
	od_SimCollider* c = od_Find(sim, id);
	if (!c)
	{
		return OD_ERROR_NOT_FOUND;
	}
	od_Collider_Destroy(&c->body);
	od_Free(c->triangles);
	od_SimCollider* end = sim->colliders.items + --sim->colliders.count;
	int index = (int)(c - sim->colliders.items);
	memmove(c, c + 1, sizeof *c * (size_t)(end - c));
	for (int i = 0; sim->surface.carried && i < sim->graph->n; ++i) // the carried forces (surface_contact.c)
	{
		int* source = &sim->surface.carriedSource[i];
		*source = *source == index ? -2 : *source > index ? *source - 1 : *source;
	}
	return OD_OK;
}

int od_Sim_GetColliderCount(const od_Sim* sim)
{
	return sim->colliders.count;
}

void od_Colliders_Destroy(od_Colliders* set)
{
	for (int k = 0; k < set->count; ++k)
	{
		od_Collider_Destroy(&set->items[k].body);
		od_Free(set->items[k].triangles);
	}
	od_Free(set->items);
	*set = (od_Colliders){ 0 };
}

void od_Colliders_BeginCall(od_Sim* sim, int steps)
{
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		od_Collider_BeginCall(&sim->colliders.items[k].body, steps * sim->def.dt);
	}
}

void od_Colliders_EndCall(od_Sim* sim, bool done)
{
	for (int k = 0; k < sim->colliders.count; ++k)
	{
		od_Collider* body = &sim->colliders.items[k].body;
		if (done)
		{
			od_Collider_EndCall(body);
		}
		else
		{
			od_Collider_Place(body, 0.0); // a failed call keeps the state it started from: the frames too
		}
	}
}
