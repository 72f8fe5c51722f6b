// Checks of caller arrays shared by the solvers: finite numbers, proper rotations.
#include "check.h"

#include "core.h"
#include "math3.h"

#include <math.h>

od_Status od_CheckRotations(const char* name, const double* rotations, int n)
{
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 r = od_M3Load(rotations + 9 * i);
		od_Mat3 rtr = od_M3MulTN(&r, &r);
		double err = 0.0;
		for (int k = 0; k < 9; ++k)
		{
			double d = rtr.m[k] - (k % 4 == 0 ? 1.0 : 0.0);
			err += d * d;
		}
		if (!(err < 1e-12) || !(od_M3Det(&r) > 0.0))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "%s[%d] is not a proper rotation (|RᵀR - I|² = %.3g, det = %.6g)",
						   name, i, err, od_M3Det(&r));
		}
	}
	return OD_OK;
}

od_Status od_CheckFinite(const char* name, const double* values, int count)
{
	for (int k = 0; k < count; ++k)
	{
		if (!isfinite(values[k]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "%s[%d][%d] is not finite", name, k / 3, k % 3);
		}
	}
	return OD_OK;
}
