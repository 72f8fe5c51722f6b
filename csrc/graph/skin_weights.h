// Skinning weights of rest points over the nearest particles of their piece (skin_weights.c).
#pragma once

#include "nearest.h"
#include "opdeform/graph.h"

// Sumner weights from the (up to m+1) nearest distances; returns the count of weights written.
int od_SumnerWeights(const double* dist, const int* near, int count, int m, int* idx, double* w);

// The k nearest particles of p in the mesh piece that skins it (graphs built from a mesh, piece_map.c) or
// in the piece of its nearest particle, by the grid (or brute force when grid is NULL); pieceSize (with a
// grid) caps k at the size of the piece. A point of a mesh piece carried by another is
// measured from that piece's anchor.
int od_NearestInPiece(const od_Graph* g, const od_NearestGrid* grid, const int* pieceSize, const double* p, int k,
					  double* dist, int* near);

// How many particles skin the rest point p of the mesh skin when m skin the body's (piece_map.c: more on a
// sheet), and the most for any point.
int od_SkinNeighbors(const od_Graph* g, const double* p, int m);
int od_SkinMostNeighbors(const od_Graph* g, int m);
