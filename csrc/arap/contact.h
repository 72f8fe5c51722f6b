// Contact with the scene colliders (contact.c): the particles' ellipsoids after a step's iterations, the
// friction rule the floor shares, and the push-out of skinned points (opdeform/colliders.h).
#pragma once

#include "opdeform/colliders.h"
#include "math3.h"
#include "sim.h"

// The fraction of a tangential slide that Coulomb friction keeps when it may take at most `limit` of it.
double od_CoulombKeep(double slide, double limit);
// Contact over the fraction [s0, s1] of the current call (before: the state at the step's start): moves the
// particles out of the colliders, with friction (scaling angularScale).
void od_ContactStep(od_Sim* sim, const od_State* before, double s0, double s1);
// Particle i's ellipsoid as its moment M = E diag(a², b², c²) Eᵀ (current frame), its largest radius, and how
// far a particle that began a step inside something may leave it per step (1 m/s).
od_Mat3 od_ParticleMoment(const od_Sim* sim, int i);
double od_ParticleReach(const od_Sim* sim, int i);
double od_RecoveryLimit(const od_Sim* sim);
// How far an ellipsoid of moment M reaches along unit n: sqrt(nᵀ M n).
double od_Support(const od_Mat3* M, od_Vec3 n);
