// Skinning weights of a rest point (Sumner et al. 2007): w_j = (1 - |p - X̄_j| / dmax)² over the m nearest
// particles, dmax the distance to the (m+1)-th, then normalised. Ties in distance are broken by particle
// index, so results are deterministic. Only particles of the connected piece of the nearest particle take
// part (for a graph built from a mesh, of the point's own mesh piece: piece_map.c): a point never follows
// a piece of the body it is not attached to. The constraints (brute-force
// search) and the mesh skin (grid search, mesh/skinning.c) get the same weights bit for bit.
#include "skin_weights.h"

#include "graph.h"

#include <float.h>
#include <stddef.h>

// Sumner weights from the (up to m+1) nearest distances; returns the count of weights written.
int od_SumnerWeights(const double* dist, const int* near, int count, int m, int* idx, double* w)
{
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

// The k nearest particles of p in the mesh piece that skins it (graphs built from a mesh, piece_map.c) or
// in the piece of its nearest particle, by the grid (or brute force when grid is NULL); pieceSize (with a
// grid) caps k at the size of the piece.
int od_NearestInPiece(const od_Graph* g, const od_NearestGrid* grid, const int* pieceSize, const double* p,
							 int k, double* dist, int* near)
{
	const int* label = NULL;
	int want = 0, size = k;
	if (g->meshPieces)
	{
		p = od_PieceMap_Locate(g->meshPieces, p, &want, &size);
		label = g->meshPieces->particlePiece;
	}
	else if (g->pieceCount > 1)
	{
		int nearest = 0;
		double d;
		if (grid)
		{
			od_NearestGrid_Query(grid, NULL, 0, p, 1, &d, &nearest);
		}
		else
		{
			od_NearestBrute(g->centers, g->n, NULL, 0, p, 1, &d, &nearest);
		}
		label = g->piece;
		want = g->piece[nearest];
		size = pieceSize ? pieceSize[want] : k;
	}
	k = size < k ? size : k;
	return grid ? od_NearestGrid_Query(grid, label, want, p, k, dist, near)
				: od_NearestBrute(g->centers, g->n, label, want, p, k, dist, near);
}

int od_Graph_SkinWeights(const od_Graph* g, const double point[3], int m, int* idx, double* w)
{
	if (m < 1)
	{
		return 0;
	}
	m = m > OD_MAX_SKIN ? OD_MAX_SKIN : m;
	double dist[OD_MAX_SKIN + 1];
	int near[OD_MAX_SKIN + 1];
	int count = od_NearestInPiece(g, NULL, NULL, point, m + 1, dist, near);
	return od_SumnerWeights(dist, near, count, m, idx, w);
}

int od_SkinNeighbors(const od_Graph* g, const double* p, int m)
{
	return g->meshPieces ? od_PieceMap_Neighbors(g->meshPieces, p, m) : m;
}

int od_SkinMostNeighbors(const od_Graph* g, int m)
{
	return g->meshPieces ? od_PieceMap_MostNeighbors(g->meshPieces, m) : m;
}
