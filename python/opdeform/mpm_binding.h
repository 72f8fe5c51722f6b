// opdeform._core.MpmWorld (mpm_binding.c).
#pragma once

#include "binding.h"

extern PyType_Spec Mpm_Spec;
