/* The parts of the _hot module defined outside _hot.c, which adds them to the module. */
#ifndef DBGLOG_PARTS_H
#define DBGLOG_PARTS_H
#include <Python.h>

/* _flush.c: `take` and `pack_batch`, the publisher thread's per-sample work. */
extern PyMethodDef flush_methods[];

/* Intern the attribute names _flush.c reads; 0, or -1 with an exception set. */
int flush_init(void);

/* _writer.c: add the Writer type (a thread that writes serialized messages with rcl); 0 or -1. */
int writer_add_type(PyObject *module);

#endif
