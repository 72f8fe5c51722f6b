// The factor's substitution (cholesky.c): it solves A x = b to round-off for lattices, chains, forests and a
// single row, with AMD and METIS orderings; split over 2, 3 and 8 threads it agrees with the serial solve and
// gives the same bits on every run; a lattice ordered by METIS does split, and its plan's longest chain
// (od_Cholesky_Span) is shorter than the serial work.
#include "cholesky.h"
#include "test_macros.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

// A graph Laplacian with a random positive diagonal on top; `pieces` disconnected copies of an nx x ny x nz
// lattice with its face diagonals (nx x 1 x 1: a chain).
static cholmod_sparse* lattice_matrix(int nx, int ny, int nz, int pieces, unsigned long long* seed,
									  cholmod_common* cc)
{
	static const int dirs[6][3] = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 }, { 1, 1, 0 }, { 0, 1, 1 }, { 1, 0, 1 } };
	int block = nx * ny * nz, n = block * pieces;
	cholmod_triplet* t = cholmod_allocate_triplet((size_t)n, (size_t)n, (size_t)n * 19, 1, CHOLMOD_REAL, cc);
	int* ti = t->i;
	int* tj = t->j;
	double* tx = t->x;
	for (int i = 0; i < n; ++i)
	{
		ti[t->nnz] = tj[t->nnz] = i;
		tx[t->nnz++] = 1e-3 + test_random(seed);
	}
	for (int p = 0; p < pieces; ++p)
	{
		for (int a = 0; a < nx; ++a)
		{
			for (int b = 0; b < ny; ++b)
			{
				for (int c = 0; c < nz; ++c)
				{
					for (int d = 0; d < 6; ++d)
					{
						int a2 = a + dirs[d][0], b2 = b + dirs[d][1], c2 = c + dirs[d][2];
						if (a2 >= nx || b2 >= ny || c2 >= nz)
						{
							continue;
						}
						int i = p * block + (a * ny + b) * nz + c, j = p * block + (a2 * ny + b2) * nz + c2;
						double w = 1.0 + 100.0 * test_random(seed);
						int rows[3] = { i, j, i }, cols[3] = { i, j, j };
						double vals[3] = { w, w, -w };
						for (int k = 0; k < 3; ++k)
						{
							ti[t->nnz] = rows[k];
							tj[t->nnz] = cols[k];
							tx[t->nnz++] = vals[k];
						}
					}
				}
			}
		}
	}
	cholmod_sparse* a = cholmod_triplet_to_sparse(t, 0, cc);
	cholmod_free_triplet(&t, cc);
	return a;
}

// max |A x - b| / max |b| for n rows of (x, y, z).
static double residual(cholmod_sparse* a, const double* x, const double* b, cholmod_common* cc)
{
	int n = (int)a->nrow;
	cholmod_dense* xd = cholmod_zeros((size_t)n, 3, CHOLMOD_REAL, cc);
	cholmod_dense* r = cholmod_zeros((size_t)n, 3, CHOLMOD_REAL, cc);
	double* xv = xd->x;
	double* rv = r->x;
	for (int i = 0; i < n; ++i)
	{
		for (int c = 0; c < 3; ++c)
		{
			xv[i + c * n] = x[3 * i + c];
			rv[i + c * n] = b[3 * i + c];
		}
	}
	double one[2] = { 1, 0 }, minus[2] = { -1, 0 };
	cholmod_sdmult(a, 0, minus, one, xd, r, cc); // r = b - A x
	double worst = 0.0, scale = 0.0;
	for (int k = 0; k < 3 * n; ++k)
	{
		worst = fabs(rv[k]) > worst ? fabs(rv[k]) : worst;
		scale = fabs(b[k]) > scale ? fabs(b[k]) : scale;
	}
	cholmod_free_dense(&xd, cc);
	cholmod_free_dense(&r, cc);
	return worst / scale;
}

static od_Cholesky* factor(cholmod_sparse* a, int ordering, int threads, cholmod_common* cc)
{
	cc->nmethods = 1;
	cc->method[0].ordering = ordering;
	// Simplicial: CHOLMOD's supernodal factorization runs OpenMP threads that outlive the test, which
	// valgrind reports as lost (the supernodal-to-simplicial copy is covered by tests/test_acceleration.py).
	cc->supernodal = CHOLMOD_SIMPLICIAL;
	cholmod_factor* f = cholmod_analyze(a, cc);
	cholmod_factorize(a, f, cc);
	od_Cholesky* ch = NULL;
	od_Status status = od_Cholesky_Create(f, cc, threads, &ch);
	cholmod_free_factor(&f, cc);
	return status == OD_OK ? ch : NULL;
}

static int check_case(int nx, int ny, int nz, int pieces, int ordering, bool mustSplit)
{
	cholmod_common cc;
	cholmod_start(&cc);
	cc.print = 0;
	unsigned long long seed = 7;
	cholmod_sparse* a = lattice_matrix(nx, ny, nz, pieces, &seed, &cc);
	int n = (int)a->nrow;
	double* b = malloc(sizeof(double) * 3 * (size_t)n);
	double* serial = malloc(sizeof(double) * 3 * (size_t)n);
	double* x = malloc(sizeof(double) * 3 * (size_t)n);
	double* again = malloc(sizeof(double) * 3 * (size_t)n);
	for (int k = 0; k < 3 * n; ++k)
	{
		b[k] = 2.0 * test_random(&seed) - 1.0;
	}
	od_Cholesky* one = factor(a, ordering, 1, &cc);
	ENSURE(one && od_Cholesky_Threads(one) == 1);
	od_Cholesky_Solve(one, NULL, b, serial);
	ENSURE_SMALL(residual(a, serial, b, &cc), 1e-12);
	memcpy(x, b, sizeof(double) * 3 * (size_t)n); // b and x may alias
	od_Cholesky_Solve(one, NULL, x, x);
	ENSURE(memcmp(x, serial, sizeof(double) * 3 * (size_t)n) == 0);
	double serialWork, span;
	od_Cholesky_Span(one, &serialWork, &span);
	ENSURE(span == serialWork);
	for (int threads = 2; threads <= 8; threads += threads < 3 ? 1 : 5)
	{
		od_Pool* pool = NULL;
		ENSURE(od_Pool_Create(threads, &pool) == OD_OK);
		od_Cholesky* ch = factor(a, ordering, od_Pool_Threads(pool), &cc);
		ENSURE(ch);
		ENSURE(!mustSplit || od_Cholesky_Threads(ch) == od_Pool_Threads(pool));
		od_Cholesky_Span(ch, &serialWork, &span); // a split plan promises its gain (cholesky.c: OD_PLAN_GAIN)
		ENSURE(od_Cholesky_Threads(ch) == 1 ? span == serialWork : span < 0.85 * serialWork);
		od_Cholesky_Solve(ch, pool, b, x);
		ENSURE_SMALL(residual(a, x, b, &cc), 1e-12);
		for (int run = 0; run < 5; ++run)
		{
			od_Cholesky_Solve(ch, pool, b, again);
			ENSURE(memcmp(x, again, sizeof(double) * 3 * (size_t)n) == 0);
		}
		od_Cholesky_Solve(ch, NULL, b, again); // no pool: the serial order, same answer to round-off
		double worst = 0.0;
		for (int k = 0; k < 3 * n; ++k)
		{
			worst = fmax(worst, fabs(again[k] - x[k]) / (1.0 + fabs(x[k])));
		}
		ENSURE_SMALL(worst, 1e-10);
		od_Cholesky_Destroy(ch);
		od_Pool_Destroy(pool);
	}
	od_Cholesky_Destroy(one);
	free(b);
	free(serial);
	free(x);
	free(again);
	cholmod_free_sparse(&a, &cc);
	cholmod_finish(&cc);
	return 0;
}

int test_cholesky(void)
{
	// The plan splits only where each thread gets OD_POOL_MIN_WORK of the pool's estimate: 6,000 columns and more.
	ENSURE(check_case(60, 10, 10, 1, CHOLMOD_METIS, true) == 0); // a beam: nested dissection splits it
	ENSURE(check_case(30, 6, 6, 1, CHOLMOD_AMD, false) == 0);
	ENSURE(check_case(500, 1, 1, 1, CHOLMOD_AMD, false) == 0);   // a chain: a path tree
	ENSURE(check_case(10, 10, 10, 9, CHOLMOD_AMD, true) == 0);   // a forest of 9 pieces
	ENSURE(check_case(1, 1, 1, 1, CHOLMOD_AMD, false) == 0);    // one row
	ENSURE(check_case(1, 1, 1, 300, CHOLMOD_METIS, false) == 0); // a diagonal matrix
	return 0;
}
