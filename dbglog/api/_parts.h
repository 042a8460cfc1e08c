/* The parts of the _hot module defined outside _hot.c, which adds them to the module. */
#ifndef DBGLOG_PARTS_H
#define DBGLOG_PARTS_H
#include <Python.h>
#include <stdint.h>
#include <time.h>

/* CLOCK_MONOTONIC in ns (the clock of the flush's GIL releases and of the writer's waits). */
static inline int64_t
monotonic_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* A fast-call function's argument count: 0, or -1 with TypeError set naming `name` and `wanted`. */
static inline int
expect_args(const char *name, Py_ssize_t given, Py_ssize_t wanted)
{
    if (given == wanted) {
        return 0;
    }
    PyErr_Format(PyExc_TypeError, "%s() takes %zd argument%s (%zd given)", name, wanted, wanted == 1 ? "" : "s",
                 given);
    return -1;
}

/* _flush.c: `take` and `pack_batch`, the publisher thread's per-sample work. */
extern PyMethodDef flush_methods[];

/* Intern the attribute names _flush.c reads; 0, or -1 with an exception set. */
int flush_init(void);

/* _writer.c: add the Writer type (a thread that writes serialized messages with rcl); 0 or -1. */
int writer_add_type(PyObject *module);

#endif
