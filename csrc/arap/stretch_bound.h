// The link weights and the stretch bound (stretch_bound.c): links that stiffen once they stretch too far.
#pragma once

#include "sim.h"

// Values per particle od_Sim.linkRaised holds: the raised softness, and the bound's scratch (each particle's
// raise, its centre and rotation ahead).
#define OD_STRETCH_SCRATCH 14

// w_ij = min(r_i, r_j) of every directed edge (od_LinkWeight) from the softness r.
void od_MakeLinkWeights(od_Sim* sim, const double* r);
// At a dynamic call's start (`ahead`: the call's duration), with a link softness and a stretch limit
// (od_Sim_SetStretchLimit): the weights made from the softness raised where links would stretch the skin past
// the limit; the edges' terms and the matrix made again only when a raised value changed.
void od_StretchBound(od_Sim* sim, double ahead);
// The raised softness back to the softness as set (a static solve, the bound turned off): the weights and the
// edges' terms made again only when a value was raised.
void od_StretchBound_Lower(od_Sim* sim);
