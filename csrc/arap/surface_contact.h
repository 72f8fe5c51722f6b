// Contact with the floor and the scene colliders inside a step's iterations (surface_contact.c): forces on
// the right side of every global solve, updated after each solve; the projection after the iterations
// (floor.c, contact.c) stays for what they leave.
#pragma once

#include "sim.h"

// The per-particle arrays, made at the first step of a simulation with a floor or a collider (none after).
od_Status od_SurfaceContact_Reserve(od_Sim* sim);
void od_SurfaceContact_Destroy(od_SurfaceContact* s);
// A call of `steps` steps begins; a step begins (no forces, the colliders' frames over it; whether a particle
// may reach a surface in it); after each global solve of its iterations (the forces the next solve sees, the
// first finds the particles near a surface; whether any is); the iterations are over (no forces left).
void od_SurfaceContact_BeginCall(od_Sim* sim, int steps);
bool od_SurfaceContact_Start(od_Sim* sim);
typedef enum od_SurfaceUpdate
{
	OD_SURFACE_NONE,  // no force acts, or they were held before
	OD_SURFACE_MOVED, // the forces changed
	OD_SURFACE_HELD,  // held from now on (under a tolerance)
} od_SurfaceUpdate;
od_SurfaceUpdate od_SurfaceContact_Update(od_Sim* sim, bool tolerance);
void od_SurfaceContact_Finish(od_Sim* sim);
// A call ends (a failed one puts the carried forces back as they were at its start).
void od_SurfaceContact_EndCall(od_Sim* sim, bool ok);
// Drops the carried forces (a new state, floor or set of colliders).
void od_SurfaceContact_Forget(od_Sim* sim);
// After the projections: rolling resistance, each connected piece's rigid turn cut by at most its contact
// patch's moment μ N a over the step (see surface_contact.c).
void od_SurfaceContact_Roll(od_Sim* sim);
// The same for a group member whose contact acts after the iterations (body_contact.c sets sim->surface.rolls):
// where the floor's and the colliders' projections write its lifts (NULL: none rolls on what it stands on), then the
// roll on the patch from those lifts, or on the one body_contact.c gave (its pairs' forces).
double* od_SurfaceContact_Lifts(od_Sim* sim);
void od_SurfaceContact_GroupRoll(od_Sim* sim, const double* lifted);
// After the iterations, before the projections: each piece left inside a surface's plane turned as a rigid body
// would be to come out (see surface_contact.c).
void od_SurfaceContact_Turn(od_Sim* sim);
// (What the projections after the iterations read of it, od_SurfaceContact_Hold and _Near, is in sim.h: floor.c
// and contact.c, below this file, read it there.)
