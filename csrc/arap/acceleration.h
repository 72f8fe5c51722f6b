// Anderson and Chebyshev acceleration of the local/global iteration (internal; see acceleration.c).
#pragma once

#include "opdeform/opdeform.h"

#include <stddef.h>

typedef struct od_Accelerator
{
	od_AcceleratorKind kind;
	int dim, window, count;
	double rho, omega;
	double* g;        // (window+1) * dim plain iterates
	double* f;        // (window+1) * dim residuals
	double* previous; // dim, Chebyshev's x_{k-1}
	double* buffer;
	size_t capacity;
	long long restarts;
} od_Accelerator;

od_Status od_Accelerator_Reset(od_Accelerator* acc, od_AcceleratorKind kind, int dim, int window, double rho);
void od_Accelerator_Restart(od_Accelerator* acc);
// Restarts the history after plain iterations: Chebyshev takes `before` (the iterate before the current one,
// whose plain iterate the current one is) as its first pair, so its next iterate is already extrapolated.
void od_Accelerator_Continue(od_Accelerator* acc, const double* before);
void od_Accelerator_Destroy(od_Accelerator* acc);
// x: in, the input x_k of the iteration; out, the next iterate. g: the plain iterate G(x_k).
void od_Accelerator_Apply(od_Accelerator* acc, double* x, const double* g);
