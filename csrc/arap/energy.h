// The objective of a step (energy.c) and the prediction it is measured against.
#pragma once

#include "sim.h"

double od_Energy(const od_Sim* sim);
void od_Predict(od_Sim* sim);

// s_i of particle i's ellipsoid in the elastic energy (od_Sim_SetStiffnessScale): 1 without a scale.
static inline double od_ElasticScale(const od_Sim* sim, int i)
{
	return sim->stiffnessScale ? sim->stiffnessScale[i] : 1.0;
}
