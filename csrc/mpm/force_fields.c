// Force fields of the MPM world (opdeform/fields.h, evaluated by fields/field.c, the same fields as the
// ARAP solver's): an acceleration and a drag rate at each grid node, after gravity and before the world's
// own noise wind (wind.c) and the colliders, v' = (v + Δt f) / (1 + Δt D) per substep.
#include "world.h"

od_FieldSet* od_MpmWorld_GetForceFields(od_MpmWorld* world)
{
	return &world->model.fields;
}

od_Vec3 od_MpmForceFields_Node(const od_MpmWorld* w, od_Vec3 x, od_Vec3 v, double dt)
{
	double drag;
	od_Vec3 f;
	od_FieldSet_Sample(&w->model.fields, x, &f, &drag);
	return od_Scale(1.0 / (1.0 + dt * drag), od_MulAdd(v, dt, f));
}
