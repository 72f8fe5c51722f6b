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

// s_i v_i of every particle: the graph's volumes without a scale. An array, not od_ElasticScale per edge: the
// test in the right side's loop cost 3 % of a 1,000-particle creature's step (2.53 -> 2.62 ms; 2.57 with the
// array, side by side).
static inline const double* od_ElasticVolumes(const od_Sim* sim)
{
	return sim->elasticVolumes ? sim->elasticVolumes : sim->graph->volumes;
}

// c_i of particle i, the damping of its prediction (od_Sim_SetParticleDamping): def.damping without one.
static inline double od_Damping(const od_Sim* sim, int i)
{
	return sim->damping ? sim->damping[i] : sim->def.damping;
}
