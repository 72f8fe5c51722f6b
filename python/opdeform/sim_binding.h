// opdeform._core.Simulation (sim_binding.c).
#pragma once

#include "binding.h"

extern PyType_Spec Sim_Spec;
