// The floor (floor.c): contact and Coulomb friction after a step's iterations.
#pragma once

#include "sim.h"

// How deep particle i's ellipsoid at (rotation, centre) reaches below the floor (<= 0: clear), less what its
// goal frame reaches below it (goals carrying the rest).
double od_FloorDepth(const od_Sim* sim, int i, const double* rotation, const double* centre);
void od_FloorStep(od_Sim* sim, const od_State* before, double* angularScale, double* lifted);
