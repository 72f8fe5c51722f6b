// Force fields (field.c): the set a simulation or an MPM world owns, and its evaluation at a point.
#pragma once

#include "math3.h"
#include "opdeform/fields.h"

typedef struct od_Field
{
	int id;
	od_FieldDef def; // direction unit
} od_Field;

struct od_FieldSet
{
	od_Field* items;
	int count, capacity, nextId;
};

void od_FieldSet_Destroy(od_FieldSet* set);
// The fields' acceleration at x (*force, m/s²) and drag rate (*drag, 1/s): a velocity v becomes
// (v + h force) / (1 + h drag) over a step h. Nothing to do (count 0) is the caller's fast path.
void od_FieldSet_Sample(const od_FieldSet* set, od_Vec3 x, od_Vec3* force, double* drag);
