// Which particles may skin a rest point, for a graph built from a mesh: only those of the point's own mesh
// piece, so that an eyeball never follows the head's particles nor a socket the eyeball's (issue 12).
//
// A point's piece is the piece of the nearest vertex of the mesh the graph was built from (exact for the
// mesh's own vertices: distance 0, and coincident vertices are welded into one piece; for a constraint
// anywhere else, the piece of the surface it is nearest to). A piece without particles of its own (a small
// piece attached to a large one, or one left out when there were fewer particles than pieces) is carried
// by its host: all its points take the weights of one anchor point (the centre of its bounding box) over
// the host's particles, so linear-blend skinning moves the whole piece by one affine map, rigidly with
// the host where the host is rigid, instead of stretching each vertex towards different particles. A rigid
// piece (a compact piece at its floor of particles, mesh_graph.c) takes its anchor's weights over its own
// particles the same way: it moves by one map, and its particles, larger than it, only carry it. The points of
// a sheet (an open piece of its own beside the body, mesh_graph.c) blend OD_SHEET_SKIN(m) particles in the
// mesh skin, where the body's blend m.
#include "piece_map.h"

#include "core.h"

#include <string.h>

od_Status od_PieceMap_Create(const od_PieceMapDef* def, int particleCount, od_PieceMap** out)
{
	size_t pieces = (size_t)def->pieceCount, points = (size_t)def->pointCount;
	od_PieceMap* map = od_AllocZero(1, sizeof *map);
	*out = NULL;
	if (map)
	{
		map->pieceCount = def->pieceCount;
		map->pointCount = def->pointCount;
		map->particlePiece = od_Alloc(sizeof(int) * (size_t)particleCount);
		map->pieceSize = od_AllocZero(pieces, sizeof(int));
		map->host = od_Alloc(sizeof(int) * pieces);
		map->anchors = od_Alloc(sizeof(double) * 3 * pieces);
		map->rigid = od_Alloc(sizeof(bool) * pieces);
		map->sheet = od_AllocZero(pieces, sizeof(bool));
		map->points = od_Alloc(sizeof(double) * 3 * (points + 1)); // + 1: never od_Alloc(0)
		map->pointPiece = od_Alloc(sizeof(int) * (points + 1));
	}
	if (!map || !map->particlePiece || !map->pieceSize || !map->host || !map->anchors || !map->rigid || !map->sheet ||
		!map->points || !map->pointPiece)
	{
		od_PieceMap_Destroy(map);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the pieces of %d mesh vertices", def->pointCount);
	}
	memcpy(map->particlePiece, def->particlePiece, sizeof(int) * (size_t)particleCount);
	memcpy(map->host, def->host, sizeof(int) * pieces);
	memcpy(map->anchors, def->anchors, sizeof(double) * 3 * pieces);
	memcpy(map->rigid, def->rigid, sizeof(bool) * pieces);
	if (def->sheet)
	{
		memcpy(map->sheet, def->sheet, sizeof(bool) * pieces);
	}
	memcpy(map->points, def->points, sizeof(double) * 3 * points);
	memcpy(map->pointPiece, def->pointPiece, sizeof(int) * points);
	od_Status status = od_NearestGrid_Create(&map->grid, map->points, def->pointCount);
	if (status != OD_OK)
	{
		od_PieceMap_Destroy(map);
		return status;
	}
	for (int i = 0; i < particleCount; ++i)
	{
		map->pieceSize[map->particlePiece[i]]++;
	}
	*out = map;
	return OD_OK;
}

void od_PieceMap_Destroy(od_PieceMap* map)
{
	if (!map)
	{
		return;
	}
	od_NearestGrid_Destroy(&map->grid);
	od_Free(map->particlePiece);
	od_Free(map->pieceSize);
	od_Free(map->host);
	od_Free(map->anchors);
	od_Free(map->rigid);
	od_Free(map->sheet);
	od_Free(map->points);
	od_Free(map->pointPiece);
	od_Free(map);
}

// The piece of rest point p: that of the nearest mesh vertex (the only one with a single piece).
static int od_PieceOf(const od_PieceMap* map, const double* p)
{
	int nearest = 0;
	double d;
	if (map->pointCount > 0 && map->pieceCount > 1)
	{
		od_NearestGrid_Query(&map->grid, NULL, 0, p, 1, &d, &nearest);
		return map->pointPiece[nearest];
	}
	return 0;
}

const double* od_PieceMap_Locate(const od_PieceMap* map, const double* p, int* want, int* size)
{
	int piece = od_PieceOf(map, p);
	*want = map->host[piece];
	*size = map->pieceSize[*want];
	return *want == piece && !map->rigid[piece] ? p : map->anchors + 3 * piece;
}

int od_PieceMap_Neighbors(const od_PieceMap* map, const double* p, int m)
{
	return map->sheet[od_PieceOf(map, p)] ? OD_SHEET_SKIN(m) : m;
}

int od_PieceMap_MostNeighbors(const od_PieceMap* map, int m)
{
	bool sheet = false;
	for (int i = 0; i < map->pieceCount; ++i)
	{
		sheet = sheet || map->sheet[i];
	}
	return sheet ? OD_SHEET_SKIN(m) : m;
}
