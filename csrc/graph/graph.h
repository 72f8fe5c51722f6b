// The rest deformation graph: ellipsoid particles joined by undirected edges (internal layout).
#pragma once

#include "opdeform/graph.h"
#include "piece_map.h"

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
	double lower[3], upper[3]; // a box around the ellipsoids (centres +- their largest radius)
};

// Gives a graph built from a mesh its map of mesh pieces (mesh/mesh_graph.c); the graph keeps a copy.
od_Status od_Graph_SetMeshPieces(od_Graph* graph, const od_PieceMapDef* def);

// How far from the graph's box a rest-space point may lie (a constraint's point, skinned by its nearest
// particles), in sizes of the graph (the box's diagonal): a point 1e20 m away made a lever that flung a 2 m
// bar 43 km; handles and pinned vertices sit on or near the body.
#define OD_REST_POINT_REACH 100.0
// A radius's bounds (issue 28): a particle's volume r³, its mass and its moment m r² stay normal doubles for
// every density a Simulation accepts (radii 1e-200 gave a zero mass: every step failed); the Fig. 1 bar scaled
// by 1e-9 and 1e9 steps.
#define OD_MIN_RADIUS 1e-12
#define OD_MAX_RADIUS 1e12

// OD_OK when p lies within OD_REST_POINT_REACH sizes of the graph's box, else OD_ERROR_ARGUMENT naming `name`.
od_Status od_Graph_CheckRestPoint(const od_Graph* g, const double p[3], const char* name);
