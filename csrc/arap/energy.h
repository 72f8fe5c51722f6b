// The objective of a step (energy.c) and the prediction it is measured against.
#pragma once

#include "sim.h"

double od_Energy(const od_Sim* sim);
void od_Predict(od_Sim* sim);
