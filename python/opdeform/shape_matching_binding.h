// opdeform._core.ShapeMatching (shape_matching_binding.c; built only with the meson option baselines).
#pragma once

#include "binding.h"

extern PyType_Spec ShapeMatching_Spec;
