// opdeform: the rest deformation graph of ellipsoid particles, shared by the ARAP solver (opdeform.h), the
// mesh layer (mesh.h) and the baselines. Immutable once made; many simulations and skins may share one.
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_GRAPH)
#error "opdeform/graph.h is the graph layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/base.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct od_Graph od_Graph;

typedef struct od_GraphDef
{
	int particleCount;
	const double* centers; // particleCount*3
	const double* radii;   // particleCount*3, all > 0
	const double* axes;    // particleCount*9 rest frames (columns are the ellipsoid axes), NULL = identity
	int edgeCount;
	const int* edges;      // edgeCount*2 undirected; no self-loops, no duplicates
} od_GraphDef;

od_GraphDef od_DefaultGraphDef(void);
od_Status od_Graph_Create(const od_GraphDef* def, od_Graph** graph);
void od_Graph_Destroy(od_Graph* graph);
int od_Graph_GetParticleCount(const od_Graph* graph);
int od_Graph_GetEdgeCount(const od_Graph* graph);
const double* od_Graph_GetCenters(const od_Graph* graph);
const double* od_Graph_GetAxes(const od_Graph* graph);
const double* od_Graph_GetRadii(const od_Graph* graph);
const int* od_Graph_GetEdges(const od_Graph* graph);
// The number of connected pieces, and for each particle the index of its piece (may be NULL).
int od_Graph_GetPieces(const od_Graph* graph, int* pieceOfParticle);
// A graph built from a mesh (mesh.h): the number of mesh pieces (connected pieces of the triangle mesh, or
// groups of joined pieces) and for each particle the mesh piece it stands for (may be NULL); 0 for a graph
// made otherwise. A rest point is skinned only by particles of its own mesh piece (od_Graph_SkinWeights).
int od_Graph_GetMeshPieces(const od_Graph* graph, int* meshPieceOfParticle);

// Sumner et al. 2007 weights of a rest-space point over its m nearest particles (of the piece of its
// nearest particle; for a graph built from a mesh, of its own mesh piece, or for a mesh piece without
// particles, of the piece that carries it). idx and w have room for m; returns the count written.
int od_Graph_SkinWeights(const od_Graph* graph, const double point[3], int m, int* idx, double* w);

#ifdef __cplusplus
}
#endif
