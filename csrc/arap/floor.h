// The floor (floor.c): contact and Coulomb friction after a step's iterations.
#pragma once

#include "sim.h"

void od_FloorStep(od_Sim* sim, const od_State* before, double* angularScale);
