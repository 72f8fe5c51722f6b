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

// The link rule, in one place: link (a, b) weighs w_ab = min(r_a, r_b) of the link softness r (NULL: 1) on both
// halves (od_Sim_SetLinkSoftness), in the per-edge weights (simulation.c) and the global matrix alike.
static inline double od_SofterEnd(const double* r, int a, int b)
{
	return r ? fmin(r[a], r[b]) : 1.0;
}

// The softness the link weights are made of: the one set, or the stretch bound's raise of it (stretch_bound.c).
static inline const double* od_LinkSoftnessInUse(const od_Sim* sim)
{
	return sim->linkSoftness && sim->linkRaised ? sim->linkRaised : sim->linkSoftness;
}

// w_ij = min(r_i, r_j) of directed edge e from i to j (od_Sim_SetLinkSoftness): 1 without a link softness.
static inline double od_LinkWeight(const od_Sim* sim, int e)
{
	return sim->linkWeight ? sim->linkWeight[e] : 1.0;
}

// w_ij (u_i + u_j) of directed edge e from particle i, u = od_ElasticVolumes: the edge's entry on row i's
// diagonal of the global matrix, over k.
static inline double od_EdgeVolume(const od_Sim* sim, const double* u, int i, int e)
{
	return od_LinkWeight(sim, e) * (u[i] + u[sim->graph->adj[e]]);
}

// c_i of particle i, the damping of its prediction (od_Sim_SetParticleDamping): def.damping without one.
static inline double od_Damping(const od_Sim* sim, int i)
{
	return sim->damping ? sim->damping[i] : sim->def.damping;
}
