// opdeform: force fields (docs/forces.md), the public C API shared by the ARAP solver and MPM.
//
// A field gives an acceleration (m/s², so the same setting moves any mass alike; a host applies its
// object's effector weights by scaling `strength`) and a drag rate (1/s) at a point. The ARAP solver adds
// them to each particle's predicted centre (od_Sim_GetForceFields), MPM to its grid velocities
// (od_MpmWorld_GetForceFields), both implicitly in the drag: v' = (v + h f) / (1 + h D).
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_FIELDS)
#error "opdeform/fields.h is the fields layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/base.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum od_FieldKind
{
	OD_FIELD_WIND = 0,      // strength along `direction`, plus `turbulence` x strength of noise
	OD_FIELD_FORCE = 1,     // from `position` outwards (strength < 0 attracts), Blender's Force
	OD_FIELD_VORTEX = 2,    // about the axis (`position`, `direction`), counter-clockwise for strength > 0
	OD_FIELD_TURBULENCE = 3 // strength x 3-D noise of feature size `size`
} od_FieldKind;

typedef struct od_FieldDef
{
	od_FieldKind kind;
	double strength;     // m/s² (default 1)
	double position[3];  // the field's origin
	double direction[3]; // its axis (wind direction, vortex axis), normalised when set (default +z)
	double turbulence;   // wind: noise amplitude as a fraction of strength (>= 0, default 0)
	double size;         // noise feature size in m (> 0, default 1)
	double falloff;      // power p >= 0 of the falloff (1 + r - minDistance)^-p beyond minDistance (default 0)
	double minDistance;  // full strength within it (>= 0); r is along the axis for wind, from the origin else
	double maxDistance;  // nothing beyond it; 0: unlimited
	double drag;         // 1/s >= 0, scaled by the falloff: a body in a wind of strength S reaches S/drag
	unsigned seed;       // of the noise
} od_FieldDef;

typedef struct od_FieldSet od_FieldSet;

od_FieldDef od_DefaultFieldDef(void);
// A field; *id for move and remove. Bad input (NaN, a zero direction, size <= 0, ...): OD_ERROR_ARGUMENT
// naming the field's parameter, nothing added.
od_Status od_FieldSet_Add(od_FieldSet* set, const od_FieldDef* def, int* id);
// Moves a field: a new origin and axis (direction NULL: kept).
od_Status od_FieldSet_Move(od_FieldSet* set, int id, const double position[3], const double* direction);
od_Status od_FieldSet_Remove(od_FieldSet* set, int id);
int od_FieldSet_Count(const od_FieldSet* set);

#ifdef __cplusplus
}
#endif
