// Colliders of the MPM world: the contact rule on top of the shared signed-distance colliders
// (collide/collider.c: plane, box, sphere, closed mesh; moving along its target over a Step/Substep call,
// placed at each substep's end).
// The grid update applies the contact rule to nodes inside (sticky, slip or separate, with Coulomb
// friction on the relative velocity); after G2P a particle that still ended inside is moved back to the
// surface and loses its approaching normal velocity, so nothing passes through.
#include "world.h"

#include "core.h"

#include <math.h>
#include <string.h>

od_MpmColliderDef od_DefaultMpmColliderDef(void)
{
	return (od_MpmColliderDef){ .shape = OD_MPM_PLANE,
								.contact = OD_MPM_SLIP,
								.friction = 0.0,
								.halfExtents = { 0.5, 0.5, 0.5 },
								.rotation = { 1, 0, 0, 0, 1, 0, 0, 0, 1 } };
}

od_Status od_MpmCollider_Init(od_MpmCollider* c, const od_MpmColliderDef* def, double dx)
{
	*c = (od_MpmCollider){ .contact = def->contact, .friction = def->friction };
	if (def->contact < OD_MPM_STICKY || def->contact > OD_MPM_SEPARATE)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: unknown contact %d", (int)def->contact);
	}
	if (!(def->friction >= 0.0) || !isfinite(def->friction))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: friction must be >= 0, got %g", def->friction);
	}
	od_ShapeDef shape = { .kind = (od_ShapeKind)def->shape,
						  .vertexCount = def->vertexCount,
						  .vertices = def->vertices,
						  .triangleCount = def->triangleCount,
						  .triangles = def->triangles,
						  .spacing = 0.5 * dx };
	memcpy(shape.halfExtents, def->halfExtents, sizeof shape.halfExtents);
	return od_Collider_Init(&c->body, &shape, def->rotation, def->translation);
}

void od_MpmCollider_Destroy(od_MpmCollider* c)
{
	od_Collider_Destroy(&c->body);
}

od_Vec3 od_MpmContactResponse(od_MpmContact contact, double friction, od_Vec3 vrel, od_Vec3 n)
{
	if (contact == OD_MPM_STICKY)
	{
		return od_V3(0, 0, 0);
	}
	double vn = od_Dot(vrel, n);
	if (contact == OD_MPM_SEPARATE && vn >= 0.0)
	{
		return vrel;
	}
	od_Vec3 vt = od_MulAdd(vrel, -vn, n);
	if (vn < 0.0 && friction > 0.0)
	{
		double len = od_Length(vt);
		double scale = len > 0.0 ? fmax(0.0, 1.0 + friction * vn / len) : 0.0;
		vt = od_Scale(scale, vt);
	}
	return vt;
}

od_Vec3 od_MpmCollider_Node(const od_MpmCollider* c, od_Vec3 x, od_Vec3 v)
{
	od_Vec3 n;
	if (od_Collider_Distance(&c->body, x, &n) >= 0.0)
	{
		return v;
	}
	od_Vec3 vc = od_Collider_Velocity(&c->body, x);
	return od_Add(vc, od_MpmContactResponse(c->contact, c->friction, od_Sub(v, vc), n));
}

void od_MpmCollider_Particle(const od_MpmCollider* c, od_Vec3* x, od_Vec3* v)
{
	od_Vec3 n;
	double d = od_Collider_Distance(&c->body, *x, &n);
	if (d >= 0.0)
	{
		return;
	}
	*x = od_MulAdd(*x, -d, n);
	od_Vec3 vc = od_Collider_Velocity(&c->body, *x), vrel = od_Sub(*v, vc);
	double vn = od_Dot(vrel, n);
	if (vn < 0.0)
	{
		*v = od_Add(vc, od_MulAdd(vrel, -vn, n));
	}
}
