// The global step (global_solve.c): best centres with the rotations held fixed; owns the factorization.
#pragma once

#include "sim.h"

od_Status od_GlobalSolver_Create(od_GlobalSolver** solver);
void od_GlobalSolver_Destroy(od_GlobalSolver* solver);
// Refactors first when the matrix's inputs changed since the last factorization (constraint version, k,
// ρ, h, threads, CHOLMOD path), then solves.
od_Status od_GlobalStep(od_Sim* sim);
// Solves A x = b in place with the factor of the last solve (its three right sides: x, y, z), for the response
// of the centres to forces (self-contact, body_contact.c). Call only after a solve of the current mode.
void od_GlobalResponse(od_Sim* sim, double* b);
