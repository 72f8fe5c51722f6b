// Linear-blend skinning weights (Sumner et al. 2007) over the nearest particles of a rest-space point.
//
// w_j = (1 - |p - X̄_j| / dmax)² for the m nearest particles, dmax the distance to the (m+1)-th, then
// normalised. Ties in distance are broken by particle index so that results are deterministic.
// Only particles of the connected piece of the nearest particle take part: a point never follows a
// piece of the body it is not attached to.
#include "graph.h"
#include "math3.h"

#include <float.h>

// Keeps the k best (distance, index) pairs sorted ascending; returns the new count.
static int od_InsertNearest(double* dist, int* idx, int count, int k, double d, int i)
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

int od_Graph_SkinWeights(const od_Graph* g, const double point[3], int m, int* idx, double* w)
{
	if (m < 1)
	{
		return 0;
	}
	if (m > OD_MAX_SKIN)
	{
		m = OD_MAX_SKIN;
	}
	double dist[OD_MAX_SKIN + 1];
	int near[OD_MAX_SKIN + 1];
	int count = 0;
	od_Vec3 p = od_V3Load(point);
	int nearest = 0;
	count = 0;
	for (int i = 0; i < g->n; ++i)
	{
		double d = od_Length(od_Sub(p, od_V3Load(g->centers + 3 * i)));
		count = od_InsertNearest(dist, &nearest, count, 1, d, i);
	}
	count = 0;
	for (int i = 0; i < g->n; ++i)
	{
		if (g->piece[i] == g->piece[nearest])
		{
			double d = od_Length(od_Sub(p, od_V3Load(g->centers + 3 * i)));
			count = od_InsertNearest(dist, near, count, m + 1, d, i);
		}
	}
	int used = count < m + 1 ? count : m;
	double dmax = count == m + 1 ? dist[m] : dist[count - 1] * (1.0 + 1e-6) + DBL_MIN * 1e10;
	double sum = 0.0;
	for (int k = 0; k < used; ++k)
	{
		double t = dmax > 0.0 ? 1.0 - dist[k] / dmax : 0.0;
		idx[k] = near[k];
		w[k] = t * t;
		sum += w[k];
	}
	for (int k = 0; k < used; ++k)
	{
		// All weights vanish only when the m nearest are as far as the (m+1)-th: share equally.
		w[k] = sum > 0.0 ? w[k] / sum : 1.0 / used;
	}
	return used;
}
