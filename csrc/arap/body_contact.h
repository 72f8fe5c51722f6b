// Contact between particles (body_contact.c): self-contact of a simulation and the bodies of a group.
#pragma once

#include "sim.h"

// Sizes the scratch for `particles` particles (the broad phase's table and per-particle arrays).
od_Status od_PairScratch_Reserve(od_PairScratch* s, int particles);
void od_PairScratch_Destroy(od_PairScratch* s);
// Checks a contact definition (the exclusion fields too when `self`).
od_Status od_BodyContact_Check(const od_BodyContactDef* def, bool self);
// Sizes sim's contact forces (the right side's share of particle contact, body_contact.c).
od_Status od_BodyContact_ReserveForces(od_Sim* sim);
// The iterations of one step of each of `count` simulations (od_Step_Start, od_Step_Advance; their states at
// the step's start in ->previous) with the pairs in contact between them: forces inside the iterations, then
// the pairs still in contact pushed apart, with friction. Pairs of one simulation only where it has
// self-contact (its selfDef), pairs of two with `between`. Fails when a solve fails or the pair list cannot
// grow.
od_Status od_BodyContact_Step(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between);
// After a group's step (its members' velocities updated, od_Step_Finish): members in contact parting, or a pressed
// member leaving its ground, faster than gravity gives in a step or 1/60 s are slowed to that speed, as the floor's
// projection stops a lone body (an inelastic impact; body_contact.c), members held by goals or position constraints
// left alone. Nothing without forces in the iterations.
// Fails when the list of interfaces cannot grow (out of memory).
// Before the members' od_Step_Finish: keeps where their particles are. After it: moves each member resting on
// another so that their patch rolls after the projections did not slide it on what it rests on (body_contact.c);
void od_BodyContact_Keep(od_PairScratch* s, od_Sim* const* sims, int count);
void od_BodyContact_Carry(od_PairScratch* s, od_Sim* const* sims, int count);
// After Carry: turns the anchors of the pairs whose slip is measured in their first particle's frame as those
// particles turned over the step (od_Slip); the friction forces stay in world coordinates.
void od_BodyContact_TurnAnchors(od_PairScratch* s, od_Sim* const* sims);
od_Status od_BodyContact_Impacts(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between);
