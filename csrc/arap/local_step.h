// The local step (local_step.c): rotations by Gauss-Seidel sweeps over the particles.
#pragma once

#include "sim.h"

void od_LocalStep_PrepareEdges(od_Sim* sim);
od_Status od_LocalStep_PreparePartition(od_Sim* sim);
void od_LocalStep(od_Sim* sim);
// A sweep's particle updates on one thread (*serial) and along its phases' longest tasks (*span) by the
// partition as it stands; equal where the sweep stays on one thread.
void od_LocalStep_Span(const od_Sim* sim, double* serial, double* span);
