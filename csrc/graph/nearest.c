// k-nearest queries. The grid has about two points per cell and is searched in rings of cells around the
// query's cell; the search stops once the k-th distance is below the distance to every unvisited cell
// (strictly, so that points tied with the k-th one are all seen and the index breaks the tie as in the
// brute force).
#include "nearest.h"

#include "core.h"
#include "math3.h"

#include <float.h>
#include <math.h>

int od_InsertNearest(double* dist, int* idx, int count, int k, double d, int i)
{
	if (count == k && (d > dist[k - 1] || (d == dist[k - 1] && i > idx[k - 1])))
	{
		return count;
	}
	int pos = count < k ? count++ : k - 1;
	while (pos > 0 && (dist[pos - 1] > d || (dist[pos - 1] == d && idx[pos - 1] > i)))
	{
		dist[pos] = dist[pos - 1];
		idx[pos] = idx[pos - 1];
		--pos;
	}
	dist[pos] = d;
	idx[pos] = i;
	return count;
}

static double od_PointDistance(const double* p, const double* q)
{
	return od_Length(od_Sub(od_V3Load(p), od_V3Load(q)));
}

int od_NearestBrute(const double* points, int count, const int* label, int want, const double p[3], int k,
					double* dist, int* idx)
{
	int found = 0;
	for (int i = 0; i < count; ++i)
	{
		if (!label || label[i] == want)
		{
			found = od_InsertNearest(dist, idx, found, k, od_PointDistance(p, points + 3 * i), i);
		}
	}
	return found;
}

// Cells of size `cell` over the extents, at least one per axis.
static double od_GridCells(const double extent[3], double cell, int dims[3])
{
	double total = 1.0;
	for (int a = 0; a < 3; ++a)
	{
		double d = floor(extent[a] / cell) + 1.0;
		d = d > 1e6 ? 1e6 : d;
		dims[a] = (int)d;
		total *= d;
	}
	return total;
}

static int od_CellOf(const od_NearestGrid* g, const double* p, int a)
{
	double t = floor((p[a] - g->origin[a]) / g->cell);
	return t < 0.0 ? 0 : t >= g->dims[a] - 1 ? g->dims[a] - 1 : (int)t;
}

od_Status od_NearestGrid_Create(od_NearestGrid* g, const double* points, int count)
{
	g->points = points;
	g->count = count;
	g->cellStart = NULL;
	g->items = NULL;
	double lo[3] = { DBL_MAX, DBL_MAX, DBL_MAX }, hi[3] = { -DBL_MAX, -DBL_MAX, -DBL_MAX }, extent[3];
	for (int i = 0; i < count; ++i)
	{
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = fmin(lo[a], points[3 * i + a]);
			hi[a] = fmax(hi[a], points[3 * i + a]);
		}
	}
	double largest = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		g->origin[a] = count ? lo[a] : 0.0;
		extent[a] = count ? hi[a] - lo[a] : 0.0;
		largest = fmax(largest, extent[a]);
	}
	if (!isfinite(largest))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "nearest search: %d points span more than the largest double on an axis",
					   count);
	}
	// The largest cell with no more than count/2 cells (bisection in log scale).
	double target = count / 2.0 > 1.0 ? count / 2.0 : 1.0;
	double small = largest * 1e-7, big = largest > 0.0 ? largest * 2.0 : 1.0;
	// small * big underflows for extents below ~1e-150 (a cell of 0: NaN cell counts), so take the roots apart
	// there; an extent below ~1e-300 (small is 0) gets one cell.
	for (int it = 0; it < 60 && small > 0.0; ++it)
	{
		double mid = small * big > DBL_MIN ? sqrt(small * big) : sqrt(small) * sqrt(big);
		if (od_GridCells(extent, mid, g->dims) > target)
		{
			small = mid;
		}
		else
		{
			big = mid;
		}
	}
	g->cell = big;
	int cells = (int)od_GridCells(extent, g->cell, g->dims);
	g->cellStart = od_AllocZero((size_t)cells + 1, sizeof(int));
	g->items = od_Alloc(sizeof(int) * (size_t)(count ? count : 1));
	int* cellOf = od_Alloc(sizeof(int) * (size_t)(count ? count : 1));
	if (!g->cellStart || !g->items || !cellOf)
	{
		od_Free(cellOf);
		od_NearestGrid_Destroy(g);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for a search grid over %d points", count);
	}
	for (int i = 0; i < count; ++i)
	{
		const double* p = points + 3 * i;
		cellOf[i] = (od_CellOf(g, p, 2) * g->dims[1] + od_CellOf(g, p, 1)) * g->dims[0] + od_CellOf(g, p, 0);
		g->cellStart[cellOf[i] + 1]++;
	}
	for (int c = 0; c < cells; ++c)
	{
		g->cellStart[c + 1] += g->cellStart[c];
	}
	for (int i = 0; i < count; ++i) // ascending i: indices stay sorted within a cell
	{
		g->items[g->cellStart[cellOf[i]]++] = i;
	}
	for (int c = cells; c > 0; --c)
	{
		g->cellStart[c] = g->cellStart[c - 1];
	}
	g->cellStart[0] = 0;
	od_Free(cellOf);
	return OD_OK;
}

void od_NearestGrid_Destroy(od_NearestGrid* g)
{
	od_Free(g->cellStart);
	od_Free(g->items);
	g->cellStart = NULL;
	g->items = NULL;
}

typedef struct od_Query
{
	const double* p;
	const int* label;
	int want, k;
	double* dist;
	int* idx;
	int found;
} od_Query;

static void od_ScanCell(const od_NearestGrid* g, int x, int y, int z, od_Query* q)
{
	int c = (z * g->dims[1] + y) * g->dims[0] + x;
	for (int s = g->cellStart[c]; s < g->cellStart[c + 1]; ++s)
	{
		int i = g->items[s];
		if (!q->label || q->label[i] == q->want)
		{
			q->found = od_InsertNearest(q->dist, q->idx, q->found, q->k, od_PointDistance(q->p, g->points + 3 * i), i);
		}
	}
}

// The distance from p to the nearest cell outside the box of Chebyshev radius r around c (infinite when
// the box covers the grid).
static double od_UnvisitedBound(const od_NearestGrid* g, const double* p, const int* c, int r)
{
	double bound = INFINITY;
	for (int a = 0; a < 3; ++a)
	{
		if (c[a] - r > 0)
		{
			bound = fmin(bound, p[a] - (g->origin[a] + (c[a] - r) * g->cell));
		}
		if (c[a] + r < g->dims[a] - 1)
		{
			bound = fmin(bound, g->origin[a] + (c[a] + r + 1) * g->cell - p[a]);
		}
	}
	return bound;
}

int od_NearestGrid_Query(const od_NearestGrid* g, const int* label, int want, const double p[3], int k,
						 double* dist, int* idx)
{
	int c[3] = { od_CellOf(g, p, 0), od_CellOf(g, p, 1), od_CellOf(g, p, 2) };
	od_Query q = { p, label, want, k, dist, idx, 0 };
	for (int r = 0;; ++r)
	{
		int z0 = c[2] - r < 0 ? 0 : c[2] - r, z1 = c[2] + r >= g->dims[2] ? g->dims[2] - 1 : c[2] + r;
		int y0 = c[1] - r < 0 ? 0 : c[1] - r, y1 = c[1] + r >= g->dims[1] ? g->dims[1] - 1 : c[1] + r;
		for (int z = z0; z <= z1; ++z)
		{
			for (int y = y0; y <= y1; ++y)
			{
				// Inside the ring's cube only the two end cells of a row are new, unless the row is on a face.
				int face = z == c[2] - r || z == c[2] + r || y == c[1] - r || y == c[1] + r;
				int step = face || r == 0 ? 1 : 2 * r;
				for (int x = c[0] - r; x <= c[0] + r; x += step)
				{
					if (x >= 0 && x < g->dims[0])
					{
						od_ScanCell(g, x, y, z, &q);
					}
				}
			}
		}
		double bound = od_UnvisitedBound(g, p, c, r);
		if (bound == INFINITY || (q.found == k && dist[k - 1] < bound))
		{
			return q.found;
		}
	}
}
