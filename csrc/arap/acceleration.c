// Acceleration of a fixed-point iteration x -> G(x) on a vector (the local/global iteration applies it to
// the particles' rotation matrices; see step.c).
//
// Anderson (type II, window m): with g_k = G(x_k) the plain iterate and f_k = g_k - x_k its residual,
// x_{k+1} = g_k - ΔG γ where γ minimizes |f_k - ΔF γ| over the last m differences (normal equations with
// a small Tikhonov term). Chebyshev (Wang 2015): x_{k+1} = ω_{k+1} (g_k - x_{k-1}) + x_{k-1} with
// ω_1 = 1, ω_2 = 2 / (2 - ρ²), ω_{k+1} = 4 / (4 - ρ² ω_k) for a spectral radius estimate ρ.
// Both are safeguarded by the energy (Peng et al. 2018): an accelerated iterate whose objective is not
// below the last accepted one is dropped for the plain iterate and the history restarts, so the objective
// still never rises.
#include "acceleration.h"

#include "core.h"

#include <math.h>
#include <string.h>

od_Status od_Accelerator_Reset(od_Accelerator* acc, od_AcceleratorKind kind, int dim, int window, double rho)
{
	int slots = window + 1;
	size_t need = (size_t)dim * (size_t)slots * 2 + (size_t)dim;
	if (need > acc->capacity)
	{
		double* p = od_Realloc(acc->buffer, sizeof(double) * need);
		if (!p)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for the accelerator history");
		}
		acc->buffer = p;
		acc->capacity = need;
	}
	acc->kind = kind;
	acc->dim = dim;
	acc->window = window;
	acc->rho = rho;
	acc->g = acc->buffer;
	acc->f = acc->buffer + (size_t)dim * slots;
	acc->previous = acc->f + (size_t)dim * slots;
	od_Accelerator_Restart(acc);
	return OD_OK;
}

void od_Accelerator_Restart(od_Accelerator* acc)
{
	acc->count = 0;
	acc->omega = 1.0;
	acc->restarts++;
}

void od_Accelerator_Continue(od_Accelerator* acc, const double* before)
{
	od_Accelerator_Restart(acc);
	if (acc->kind == OD_ACCELERATE_CHEBYSHEV)
	{
		acc->count = 1;
		memcpy(acc->previous, before, sizeof(double) * acc->dim);
	}
}

void od_Accelerator_Destroy(od_Accelerator* acc)
{
	od_Free(acc->buffer);
	memset(acc, 0, sizeof *acc);
}

static double od_DotN(const double* a, const double* b, int n)
{
	double s = 0.0;
	for (int k = 0; k < n; ++k)
	{
		s += a[k] * b[k];
	}
	return s;
}

// Solves the small SPD system a y = b in place (Cholesky); returns 0 if not positive definite.
static int od_SolveSmallSpd(double* a, double* b, int m)
{
	for (int j = 0; j < m; ++j)
	{
		double d = a[j * m + j];
		for (int k = 0; k < j; ++k)
		{
			d -= a[j * m + k] * a[j * m + k];
		}
		if (!(d > 0.0))
		{
			return 0;
		}
		d = sqrt(d);
		a[j * m + j] = d;
		for (int i = j + 1; i < m; ++i)
		{
			double s = a[i * m + j];
			for (int k = 0; k < j; ++k)
			{
				s -= a[i * m + k] * a[j * m + k];
			}
			a[i * m + j] = s / d;
		}
	}
	for (int i = 0; i < m; ++i)
	{
		double s = b[i];
		for (int k = 0; k < i; ++k)
		{
			s -= a[i * m + k] * b[k];
		}
		b[i] = s / a[i * m + i];
	}
	for (int i = m - 1; i >= 0; --i)
	{
		double s = b[i];
		for (int k = i + 1; k < m; ++k)
		{
			s -= a[k * m + i] * b[k];
		}
		b[i] = s / a[i * m + i];
	}
	return 1;
}

#define OD_MAX_WINDOW 16

// x (in: the input x_k of the iteration; out: the accelerated iterate), g = G(x_k).
static void od_AndersonApply(od_Accelerator* acc, double* x, const double* g)
{
	int n = acc->dim, slots = acc->window + 1;
	int slot = acc->count % slots;
	double* gs = acc->g + (size_t)n * slot;
	double* fs = acc->f + (size_t)n * slot;
	for (int k = 0; k < n; ++k)
	{
		gs[k] = g[k];
		fs[k] = g[k] - x[k];
	}
	acc->count++;
	int m = (acc->count - 1 < acc->window ? acc->count - 1 : acc->window);
	if (m == 0)
	{
		memcpy(x, g, sizeof(double) * n);
		return;
	}
	// Differences against the newest slot: ΔF_c = f_new - f_old(c), ΔG_c likewise.
	double gram[OD_MAX_WINDOW * OD_MAX_WINDOW], rhs[OD_MAX_WINDOW];
	const double* col[OD_MAX_WINDOW];
	for (int c = 0; c < m; ++c)
	{
		col[c] = acc->f + (size_t)n * ((acc->count - 2 - c) % slots);
	}
	// gram = (f - f_c)·(f - f_d) expanded with dot products of stored vectors.
	double ff = od_DotN(fs, fs, n);
	double fc[OD_MAX_WINDOW];
	for (int c = 0; c < m; ++c)
	{
		fc[c] = od_DotN(fs, col[c], n);
	}
	for (int c = 0; c < m; ++c)
	{
		for (int d = 0; d <= c; ++d)
		{
			double v = ff - fc[c] - fc[d] + od_DotN(col[c], col[d], n);
			gram[c * m + d] = gram[d * m + c] = v;
		}
		rhs[c] = ff - fc[c];
	}
	double trace = 0.0;
	for (int c = 0; c < m; ++c)
	{
		trace += gram[c * m + c];
	}
	for (int c = 0; c < m; ++c)
	{
		gram[c * m + c] += 1e-10 * trace + 1e-300;
	}
	if (!od_SolveSmallSpd(gram, rhs, m))
	{
		memcpy(x, g, sizeof(double) * n);
		od_Accelerator_Restart(acc);
		return;
	}
	// x = g - Σ γ_c (g - g_c) = (1 - Σγ) g + Σ γ_c g_c
	double sum = 0.0;
	for (int c = 0; c < m; ++c)
	{
		sum += rhs[c];
	}
	for (int k = 0; k < n; ++k)
	{
		x[k] = (1.0 - sum) * g[k];
	}
	for (int c = 0; c < m; ++c)
	{
		const double* gc = acc->g + (size_t)n * ((acc->count - 2 - c) % slots);
		for (int k = 0; k < n; ++k)
		{
			x[k] += rhs[c] * gc[k];
		}
	}
}

static void od_ChebyshevApply(od_Accelerator* acc, double* x, const double* g)
{
	int n = acc->dim;
	acc->count++;
	double rho2 = acc->rho * acc->rho;
	acc->omega = acc->count == 1 ? 1.0 : acc->count == 2 ? 2.0 / (2.0 - rho2) : 4.0 / (4.0 - rho2 * acc->omega);
	for (int k = 0; k < n; ++k)
	{
		double older = acc->count == 1 ? x[k] : acc->previous[k];
		acc->previous[k] = x[k];
		x[k] = acc->omega * (g[k] - older) + older;
	}
}

void od_Accelerator_Apply(od_Accelerator* acc, double* x, const double* g)
{
	if (acc->kind == OD_ACCELERATE_ANDERSON)
	{
		od_AndersonApply(acc, x, g);
	}
	else if (acc->kind == OD_ACCELERATE_CHEBYSHEV)
	{
		od_ChebyshevApply(acc, x, g);
	}
	else
	{
		memcpy(x, g, sizeof(double) * acc->dim);
	}
}
