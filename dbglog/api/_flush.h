/* The publisher thread's per-sample work (_flush.c), added to the _hot module by _hot.c. */
#ifndef DBGLOG_FLUSH_H
#define DBGLOG_FLUSH_H
#include <Python.h>

/* `take` and `pack_batch`. */
extern PyMethodDef flush_methods[];

/* Intern the attribute names _flush.c reads; 0, or -1 with an exception set. */
int flush_init(void);

#endif
