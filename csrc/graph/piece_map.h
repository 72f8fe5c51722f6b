// Which particles may skin a rest point, for a graph built from a mesh (piece_map.c).
#pragma once

#include "nearest.h"

#include <stdbool.h>

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
