// Checks of caller arrays (check.c); each fails with OD_ERROR_ARGUMENT and a message naming `name`.
#pragma once

#include "opdeform/base.h"

// count numbers, read as rows of three in the message.
od_Status od_CheckFinite(const char* name, const double* values, int count);
// n row-major 3x3 matrices, each orthonormal to 1e-6 with a positive determinant.
od_Status od_CheckRotations(const char* name, const double* rotations, int n);
