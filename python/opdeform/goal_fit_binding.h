// opdeform._core, goal part (goal_fit_binding.c): the GoalFit type.
#pragma once

#include "binding.h"

extern PyType_Spec GoalFit_Spec;
