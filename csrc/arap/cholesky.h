// The global matrix's Cholesky factor, copied from CHOLMOD into a compact layout of our own, and its
// forward and back substitution for the three right sides (x, y, z) at once. See cholesky.c.
#pragma once

#include "opdeform/base.h"
#include "pool.h"

#include <cholmod.h>

typedef struct od_Cholesky od_Cholesky;

// Copies the factor (converted in place to a simplicial LLᵀ) and plans the substitution for `threads`
// threads (1: serial). CHOLMOD's factor may be freed afterwards.
od_Status od_Cholesky_Create(cholmod_factor* factor, cholmod_common* common, int threads, od_Cholesky** out);
void od_Cholesky_Destroy(od_Cholesky* chol);
// The threads the plan splits the substitution over (1 when the elimination tree does not split well).
int od_Cholesky_Threads(const od_Cholesky* chol);
// One entry of the factor in one substitution pass (three right sides), in nanoseconds: the pool's measure of a
// pass's work (docs/speed.md).
#define OD_ENTRY_NS 0.8
// A factor with fewer entries is substituted serially at any thread count: no job of it fills two of the pool's
// threads (OD_POOL_MIN_WORK each).
#define OD_CHOLESKY_SPLIT_ENTRIES (2.0 * OD_POOL_MIN_WORK / OD_ENTRY_NS)
// A solve's work in factor entries (each column counts one more, each row of b and x read or written through
// the permutation one): on one thread (*serial) and along the plan's longest chain (*span: each level's job on
// the threads the pool gives it, the top in both passes, the sums taken from the accumulators and the
// permutation; equal to *serial when serial).
void od_Cholesky_Span(const od_Cholesky* chol, double* serial, double* span);
// Solves A x = b; b and x hold n rows of (x, y, z) in particle order and may alias. With a pool whose
// thread count matches the plan, independent subtrees of the elimination tree run in parallel; the
// result does not depend on which thread ran what.
void od_Cholesky_Solve(od_Cholesky* chol, od_Pool* pool, const double* b, double* x);
