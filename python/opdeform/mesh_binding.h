// opdeform._core, mesh part (mesh_binding.c): the Skin type and graph_from_mesh, parse_mesh, format_mesh, and the
// mesh graph's piece constants.
#pragma once

#include "binding.h"

extern PyType_Spec Skin_Spec;
extern PyMethodDef Mesh_Functions[];

// Adds the mesh graph's constants a caller reasons with (SMALL_PIECE_PARTICLES, SHELL_PARTICLES, ROOT_LINKS,
// SMALL_PIECE_RATIO, SMALL_PIECE_SHARE, SMALL_PIECE_EXTRA: opdeform/mesh.h) to the module: 0, or -1 with an
// exception set.
int Mesh_AddConstants(PyObject* module);
