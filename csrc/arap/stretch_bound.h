// The link weights and the stretch bound (stretch_bound.c): links that stiffen once they stretch too far.
#pragma once

#include "sim.h"

// w_ij = min(r_i, r_j) of every directed edge (od_LinkWeight) from the softness r.
void od_MakeLinkWeights(od_Sim* sim, const double* r);
// At a dynamic call's start, with a link softness and a stretch limit (od_Sim_SetStretchLimit): the weights
// made from the softness raised where links stretch past the limit; the edges' terms and the matrix made again
// only when a raised value changed.
void od_StretchBound(od_Sim* sim, double ahead);
