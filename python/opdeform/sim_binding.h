// opdeform._core.Simulation and opdeform._core.ContactGroup (sim_binding.c).
#pragma once

#include "binding.h"

extern PyType_Spec Sim_Spec;
extern PyType_Spec Group_Spec;
