// The local step (local_step.c): rotations by Gauss-Seidel sweeps over the particles.
#pragma once

#include "sim.h"

void od_LocalStep_PrepareEdges(od_Sim* sim);
od_Status od_LocalStep_PreparePartition(od_Sim* sim);
void od_LocalStep(od_Sim* sim);
