// Which particles may skin a rest point, for a graph built from a mesh (piece_map.c).
#pragma once

#include "nearest.h"

#include <stdbool.h>

// Most skinning neighbours a point or constraint may have.
#define OD_MAX_SKIN 16
// The particles that skin a vertex of an open sheet of its own when m skin one of the body's: half as many again
// (piece_map.c). On the kid's skirt (docs/goals.md), a cone held at its waistband, the hem's particles swing
// 40-70 mm while the row above keeps to its goals, and with 4 each an edge across the seam stretched 1.56x at
// the Floppy look (1.37-1.61x over 50-400 particles); with 6, 1.20-1.44x.
#define OD_SHEET_SKIN(m) ((3 * (m) + 1) / 2 < OD_MAX_SKIN ? (3 * (m) + 1) / 2 : OD_MAX_SKIN)

// What the mesh layer knows when it builds a graph: the mesh piece (a connected piece of the triangle
// mesh, or a group of joined pieces) that each particle stands for, and the mesh's own vertices with their
// pieces, so that any rest point (a vertex of the same mesh, or any point, for a constraint) finds its piece.
typedef struct od_PieceMapDef
{
	int pieceCount;
	const int* particlePiece; // particleCount: the piece each particle stands for
	const int* host;          // pieceCount: the piece itself when it has particles, else the piece that carries it
	const double* anchors;    // pieceCount*3: where a carried piece takes the weights all its vertices share
	const bool* rigid;        // pieceCount: a piece with particles whose vertices share its anchor's weights too
	const bool* sheet;        // pieceCount: an open sheet of its own, skinned over more neighbours (or NULL: none)
	int pointCount;
	const double* points;     // pointCount*3: the mesh's vertices (none needed for a single piece)
	const int* pointPiece;    // pointCount
} od_PieceMapDef;

typedef struct od_PieceMap
{
	int pieceCount;
	int* particlePiece; // particleCount
	int* pieceSize;     // pieceCount: particles of each piece
	int* host;          // pieceCount
	double* anchors;    // pieceCount*3
	bool* rigid;        // pieceCount
	bool* sheet;        // pieceCount
	int pointCount;
	double* points;     // pointCount*3
	int* pointPiece;    // pointCount
	od_NearestGrid grid; // over points
} od_PieceMap;

od_Status od_PieceMap_Create(const od_PieceMapDef* def, int particleCount, od_PieceMap** map);
void od_PieceMap_Destroy(od_PieceMap* map);
// The piece whose particles skin the rest point p (*want) and how many it has (*size); returns the point
// whose weights p takes: p itself, or the anchor of the piece p belongs to when another piece carries it or
// the piece is rigid.
const double* od_PieceMap_Locate(const od_PieceMap* map, const double* p, int* want, int* size);
// How many particles skin the rest point p when m skin a point of the body: OD_SHEET_SKIN(m) on a sheet.
int od_PieceMap_Neighbors(const od_PieceMap* map, const double* p, int m);
// The most particles that skin any point when m skin a point of the body.
int od_PieceMap_MostNeighbors(const od_PieceMap* map, int m);
