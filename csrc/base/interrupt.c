// The interrupt handler of long calls: one per thread, polled by od_CheckInterrupt between steps, iterations
// and MPM substeps.
//
// Design: the check reads the clock (a vDSO call, ~20 ns) and polls the handler only when
// OD_INTERRUPT_INTERVAL has passed since the handler was set or last polled. A host's handler may be costly:
// the Python binding's takes the GIL back to run PyErr_CheckSignals, and taking the GIL can wait up to the
// interpreter's 5 ms switch interval when another thread runs Python, so polling every step would slow a
// step(400000) of 28 us steps many times over; every 50 ms bounds that to a few percent and answers Ctrl-C
// well within a second.
#include "interrupt.h"

#include "clock.h"
#include "core.h"

#include <stddef.h>

#define OD_INTERRUPT_INTERVAL 0.05

static _Thread_local od_InterruptFn* od_handler;
static _Thread_local void* od_handlerContext;
static _Thread_local double od_lastPoll;

void od_SetInterruptHandler(od_InterruptFn* handler, void* context)
{
	od_handler = handler;
	od_handlerContext = context;
	od_lastPoll = handler ? od_Clock() : 0.0;
}

od_Status od_CheckInterrupt(void)
{
	if (!od_handler)
	{
		return OD_OK;
	}
	double now = od_Clock();
	if (now - od_lastPoll < OD_INTERRUPT_INTERVAL)
	{
		return OD_OK;
	}
	od_lastPoll = now;
	return od_handler(od_handlerContext) ? od_Fail(OD_ERROR_INTERRUPTED, "interrupted") : OD_OK;
}
