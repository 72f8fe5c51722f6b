// opdeform._core, mesh part (mesh_binding.c): the Skin type and graph_from_mesh, parse_mesh, format_mesh.
#pragma once

#include "binding.h"

extern PyType_Spec Skin_Spec;
extern PyMethodDef Mesh_Functions[];
