// The interrupt check of long calls (interrupt.c; the handler is set with od_SetInterruptHandler, base.h).
#pragma once

#include "opdeform/base.h"

// OD_ERROR_INTERRUPTED (with a message) when the calling thread's handler, polled at most every
// OD_INTERRUPT_INTERVAL seconds, asks to stop; OD_OK otherwise and always when no handler is set.
od_Status od_CheckInterrupt(void);
