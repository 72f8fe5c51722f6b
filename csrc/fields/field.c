// Force fields (docs/forces.md): wind, point force, vortex and turbulence with Blender's falloff and a drag
// rate, evaluated at a point. The only file that holds their maths; the ARAP prediction (arap/energy.c) and
// the MPM grid update (mpm/force_fields.c) both call od_FieldSet_Sample.
//
// Falloff (Blender's effector falloff without its max-distance ramp): 1 within minDistance, 0 beyond a
// positive maxDistance, (1 + r - minDistance)^-p between; r is the distance along the axis for wind (a
// plane of wind, as Blender measures it) and from the origin for the others.
// Noise (wind turbulence, the turbulence field): a vector value noise, random vectors in [-1, 1]³ at the
// integer lattice of x / size, blended by the quintic fade: smooth (C²), cheap (8 hashes per channel) and
// the same bits on every platform.
//
// Drag is applied implicitly by the callers, v' = (v + h f) / (1 + h D): stable at any D h (an explicit
// v' = v + h (f - D v) overshoots for D h > 2), and the speed settles at f / D, the wind's own speed.
#include "field.h"

#include "buffer.h"
#include "core.h"

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

od_FieldDef od_DefaultFieldDef(void)
{
	return (od_FieldDef){ .kind = OD_FIELD_WIND, .strength = 1.0, .direction = { 0, 0, 1 }, .size = 1.0, .seed = 1 };
}

static od_Status od_CheckField(const od_FieldDef* d)
{
	if (d->kind < OD_FIELD_WIND || d->kind > OD_FIELD_TURBULENCE)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "force field: kind = %d is not wind, force, vortex or turbulence",
					   (int)d->kind);
	}
	const char* names[] = { "strength", "turbulence", "size", "falloff", "min_distance", "max_distance", "drag" };
	const double values[] = { d->strength, d->turbulence, d->size, d->falloff, d->minDistance, d->maxDistance, d->drag };
	for (int k = 0; k < 7; ++k)
	{
		bool ok = isfinite(values[k]) && (k == 0 || values[k] >= 0.0) && (k != 2 || values[k] > 0.0);
		if (!ok)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "force field: %s = %g must be finite%s", names[k], values[k],
						   k == 0 ? "" : k == 2 ? " and > 0" : " and >= 0");
		}
	}
	if (d->maxDistance > 0.0 && d->maxDistance < d->minDistance) // else the min distance hid the max
	{
		return od_Fail(OD_ERROR_ARGUMENT, "force field: max_distance = %g must be 0 (none) or >= min_distance = %g",
					   d->maxDistance, d->minDistance);
	}
	if (!od_IsFinite3(d->position))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "force field: position must be three finite numbers");
	}
	return OD_OK;
}

// The unit axis of `direction`, or a failure naming it.
static od_Status od_UnitAxis(const double direction[3], double out[3])
{
	od_Vec3 d = od_V3Load(direction);
	double length = od_Length(d);
	if (!(length > 0.0) || !isfinite(length))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "force field: direction must be finite and not zero");
	}
	od_V3Store(out, od_Scale(1.0 / length, d));
	return OD_OK;
}

static od_Field* od_Find(od_FieldSet* set, int id)
{
	for (int k = 0; k < set->count; ++k)
	{
		if (set->items[k].id == id)
		{
			return &set->items[k];
		}
	}
	od_Fail(OD_ERROR_NOT_FOUND, "no force field %d", id);
	return NULL;
}

od_Status od_FieldSet_Add(od_FieldSet* set, const od_FieldDef* def, int* id)
{
	od_Field f = { .id = set->nextId, .def = *def };
	od_Status status = od_CheckField(def);
	status = status == OD_OK ? od_UnitAxis(def->direction, f.def.direction) : status;
	status = status == OD_OK ? od_Grow((void**)&set->items, &set->capacity, set->count + 1, sizeof(od_Field),
									   "force fields")
							 : status;
	if (status != OD_OK)
	{
		return status;
	}
	set->items[set->count++] = f;
	*id = set->nextId++;
	return OD_OK;
}

od_Status od_FieldSet_Move(od_FieldSet* set, int id, const double position[3], const double* direction)
{
	od_Field* f = od_Find(set, id);
	double axis[3];
	if (!f)
	{
		return OD_ERROR_NOT_FOUND;
	}
	od_Status status = od_IsFinite3(position) ? OD_OK
						   : od_Fail(OD_ERROR_ARGUMENT, "force field: position must be three finite numbers");
	status = status == OD_OK && direction ? od_UnitAxis(direction, axis) : status;
	if (status != OD_OK)
	{
		return status;
	}
	memcpy(f->def.position, position, sizeof axis);
	if (direction)
	{
		memcpy(f->def.direction, axis, sizeof axis);
	}
	return OD_OK;
}

od_Status od_FieldSet_Remove(od_FieldSet* set, int id)
{
	od_Field* f = od_Find(set, id);
	if (!f)
	{
		return OD_ERROR_NOT_FOUND;
	}
	memmove(f, f + 1, sizeof *f * (size_t)(set->items + --set->count - f));
	return OD_OK;
}

int od_FieldSet_Count(const od_FieldSet* set)
{
	return set->count;
}

void od_FieldSet_Destroy(od_FieldSet* set)
{
	od_Free(set->items);
	*set = (od_FieldSet){ 0 };
}

// A value in [-1, 1] for lattice point (i, j, k) of channel c (a 32-bit integer hash: lowbias32).
static double od_LatticeValue(int32_t i, int32_t j, int32_t k, uint32_t key)
{
	uint32_t h = key ^ (uint32_t)i * 0x8da6b343u ^ (uint32_t)j * 0xd8163841u ^ (uint32_t)k * 0xcb1ab31fu;
	h ^= h >> 16;
	h *= 0x7feb352du;
	h ^= h >> 15;
	h *= 0x846ca68bu;
	h ^= h >> 16;
	return (double)h * (2.0 / 4294967295.0) - 1.0;
}

static double od_Fade(double t)
{
	return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// The vector noise at p (lattice units), each channel in [-1, 1].
static od_Vec3 od_Noise(od_Vec3 p, unsigned seed)
{
	double base[3] = { floor(p.x), floor(p.y), floor(p.z) }, w[3][2], out[3] = { 0, 0, 0 };
	if (!(fabs(base[0]) < 1e9 && fabs(base[1]) < 1e9 && fabs(base[2]) < 1e9))
	{
		return od_V3(0, 0, 0); // far outside any scene: no lattice
	}
	double frac[3] = { p.x - base[0], p.y - base[1], p.z - base[2] };
	for (int a = 0; a < 3; ++a)
	{
		w[a][1] = od_Fade(frac[a]);
		w[a][0] = 1.0 - w[a][1];
	}
	for (int corner = 0; corner < 8; ++corner)
	{
		int di = corner & 1, dj = (corner >> 1) & 1, dk = corner >> 2;
		double weight = w[0][di] * w[1][dj] * w[2][dk];
		for (int c = 0; c < 3; ++c)
		{
			out[c] += weight * od_LatticeValue((int32_t)base[0] + di, (int32_t)base[1] + dj, (int32_t)base[2] + dk,
											   seed * 0x9e3779b9u + (uint32_t)c * 0x85ebca6bu);
		}
	}
	return od_V3Load(out);
}

// The falloff factor at distance r.
static double od_Falloff(const od_FieldDef* d, double r)
{
	if (r <= d->minDistance)
	{
		return 1.0;
	}
	if (d->maxDistance > 0.0 && r > d->maxDistance)
	{
		return 0.0;
	}
	return d->falloff > 0.0 ? pow(1.0 + r - d->minDistance, -d->falloff) : 1.0;
}

// The unit vector of v, or zero for a zero vector (on a force's centre, a vortex's axis).
static od_Vec3 od_UnitOrZero(od_Vec3 v)
{
	double length = od_Length(v);
	return length > 0.0 ? od_Scale(1.0 / length, v) : od_V3(0, 0, 0);
}

// One field's acceleration at x (before its falloff) and the distance its falloff reads.
static od_Vec3 od_FieldForce(const od_FieldDef* d, od_Vec3 x, double* r)
{
	od_Vec3 axis = od_V3Load(d->direction), rel = od_Sub(x, od_V3Load(d->position));
	*r = d->kind == OD_FIELD_WIND ? fabs(od_Dot(axis, rel)) : od_Length(rel);
	switch (d->kind)
	{
		case OD_FIELD_WIND:
			return d->turbulence > 0.0
					   ? od_Scale(d->strength, od_MulAdd(axis, d->turbulence, od_Noise(od_Scale(1.0 / d->size, x), d->seed)))
					   : od_Scale(d->strength, axis);
		case OD_FIELD_FORCE:
			return od_Scale(d->strength, od_UnitOrZero(rel));
		case OD_FIELD_VORTEX:
			return od_Scale(d->strength, od_UnitOrZero(od_Cross(axis, rel)));
		default:
			return od_Scale(d->strength, od_Noise(od_Scale(1.0 / d->size, x), d->seed));
	}
}

void od_FieldSet_Sample(const od_FieldSet* set, od_Vec3 x, od_Vec3* force, double* drag)
{
	*force = od_V3(0, 0, 0);
	*drag = 0.0;
	for (int k = 0; k < set->count; ++k)
	{
		const od_FieldDef* d = &set->items[k].def;
		double r;
		od_Vec3 f = od_FieldForce(d, x, &r);
		double falloff = od_Falloff(d, r);
		*force = od_MulAdd(*force, falloff, f);
		*drag += falloff * d->drag;
	}
}
