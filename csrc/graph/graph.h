// The rest deformation graph: ellipsoid particles joined by undirected edges (internal layout).
#pragma once

#include "opdeform/graph.h"
#include "piece_map.h"

// Most skinning neighbours a point or constraint may have.
#define OD_MAX_SKIN 16

struct od_Graph
{
	int n;
	int edgeCount;
	double* centers;  // n*3, X̄
	double* axes;     // n*9, Ē (columns are the ellipsoid axes)
	double* radii;    // n*3
	double* volumes;  // n
	double* moments;  // n*9, Ā = Ē A Ēᵀ with A = 0.2 v diag(a², b², c²)
	int* edges;       // edgeCount*2
	int* adjStart;    // n+1, CSR of the symmetric adjacency
	int* adj;         // 2*edgeCount, sorted per particle
	int pieceCount;
	int* piece;       // n, connected piece of each particle
	od_PieceMap* meshPieces; // built from a mesh: the mesh piece of each particle and point; NULL otherwise
};

// Gives a graph built from a mesh its map of mesh pieces (mesh/mesh_graph.c); the graph keeps a copy.
od_Status od_Graph_SetMeshPieces(od_Graph* graph, const od_PieceMapDef* def);
