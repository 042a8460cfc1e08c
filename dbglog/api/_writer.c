/* Writer: a thread of its own that hands serialized messages to rcl, never touching Python (see
 * _hot.pyi and docs/api.md, "The writer thread").
 *
 * The publisher thread (Python) builds each message with the GIL held and `submit`s a copy of its
 * bytes with the rcl publisher's address; this thread calls rcl_publish_serialized_message for each,
 * in order. It holds no GIL, ever, so the robot's Python threads never wait for a DDS write. It is an
 * ordinary thread: under SCHED_IDLE, a write preempted inside Fast DDS's shared-memory push kept that
 * port's interprocess mutex, and on a busy machine every other publisher to the same subscriber waited
 * for it (docs/api.md, "Why the writer thread is an ordinary thread"). rcl's functions come as addresses
 * from ctypes (dbglog/_ros/_nogil.py): the extension is built without ROS headers.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <errno.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include "_parts.h"

#if PY_VERSION_HEX < 0x030D0000
#define Py_IsFinalizing _Py_IsFinalizing
#endif

/* rcutils_uint8_array_t (rcl_serialized_message_t): the bytes, their length and capacity, and an
 * allocator that rcl never calls to publish. */
typedef struct {
    void *allocate, *deallocate, *reallocate, *zero_allocate, *state;
} Allocator;

typedef struct {
    uint8_t *buffer;
    size_t buffer_length;
    size_t buffer_capacity;
    Allocator allocator;
} SerializedMessage;

typedef int32_t (*rcl_publish_fn)(const void *publisher, const SerializedMessage *message, void *allocation);
typedef void (*reset_fn)(void);

typedef struct Job {
    struct Job *next;
    const void *publisher;
    int64_t submitted;     /* CLOCK_MONOTONIC ns */
    size_t size;
    uint8_t data[];
} Job;

typedef struct {
    PyObject_HEAD
    pthread_mutex_t mutex;
    pthread_cond_t work;   /* a job was queued, or stop */
    pthread_cond_t done;   /* a job was written: room, or idle */
    pthread_t thread;
    Job *head, *tail;
    size_t queued_bytes;
    size_t capacity;       /* bytes queued at most before `submit` waits */
    int busy;              /* a job is being written */
    int refusing;          /* full, and a submit already waited `full_wait` in vain: refuse at once */
    double full_wait;      /* seconds `submit` waits for room before it refuses (BufferError); until a
                            * message is written later submits are refused at once, so the publisher
                            * thread never holds its lock for long */
    int64_t busy_submitted; /* when the job being written was submitted */
    int64_t longest_ns;    /* the longest a written message waited (submit to written) since `stats` */
    int stopping;
    int started;
    int ready;             /* the thread has set `native_id` */
    long native_id;        /* the thread's id (gettid) */
    unsigned long long written, failed;
    rcl_publish_fn publish;
    reset_fn reset;
    pid_t pid;             /* the process that started the thread (a fork's child has none) */
} Writer;

static void *
writer_main(void *arg)
{
    Writer *w = arg;
    pthread_mutex_lock(&w->mutex);
    w->native_id = (long)syscall(SYS_gettid);
    w->ready = 1;
    pthread_cond_broadcast(&w->done);
    for (;;) {
        while (w->head == NULL && !w->stopping) {
            pthread_cond_wait(&w->work, &w->mutex);
        }
        if (w->head == NULL) {
            break;
        }
        Job *job = w->head;
        w->head = job->next;
        if (w->head == NULL) {
            w->tail = NULL;
        }
        w->busy = 1;
        w->busy_submitted = job->submitted;
        pthread_mutex_unlock(&w->mutex);
        SerializedMessage message = {job->data, job->size, job->size, {0}};
        int32_t ret = w->publish(job->publisher, &message, NULL);
        if (ret != 0) {
            w->reset(); /* rcl's error state is per thread: this one's */
        }
        size_t size = job->size;
        int64_t waited = monotonic_ns() - job->submitted;
        free(job);
        pthread_mutex_lock(&w->mutex);
        if (waited > w->longest_ns) {
            w->longest_ns = waited;
        }
        w->busy = 0;
        w->refusing = 0;
        w->queued_bytes -= size;
        if (ret == 0) {
            w->written++;
        }
        else {
            w->failed++;
        }
        pthread_cond_broadcast(&w->done);
    }
    pthread_mutex_unlock(&w->mutex);
    return NULL;
}

/* Absolute CLOCK_MONOTONIC time `seconds` (0 to 10^6) from now (the condition variables use that clock). */
static struct timespec
deadline_in(double seconds)
{
    seconds = seconds < 0 ? 0 : (seconds > 1e6 ? 1e6 : seconds);
    int64_t at = monotonic_ns() + (int64_t)(seconds * 1e9);
    struct timespec ts = {(time_t)(at / 1000000000), (long)(at % 1000000000)};
    return ts;
}

static PyObject *
writer_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    static char *names[] = {"publish", "reset", "capacity", "full_wait", NULL};
    unsigned long long publish, reset;
    Py_ssize_t capacity;
    double full_wait = 1.0;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "KKn|d:Writer", names, &publish, &reset, &capacity,
                                     &full_wait)) {
        return NULL;
    }
    if (publish == 0 || reset == 0 || capacity <= 0) {
        PyErr_SetString(PyExc_ValueError, "Writer: the rcl functions' addresses and a capacity are needed");
        return NULL;
    }
    Writer *w = (Writer *)type->tp_alloc(type, 0);
    if (w == NULL) {
        return NULL;
    }
    w->publish = (rcl_publish_fn)(uintptr_t)publish;
    w->reset = (reset_fn)(uintptr_t)reset;
    w->capacity = (size_t)capacity;
    w->full_wait = full_wait;
    w->pid = getpid();
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    if (pthread_mutex_init(&w->mutex, NULL) != 0 || pthread_cond_init(&w->work, &attr) != 0
        || pthread_cond_init(&w->done, &attr) != 0) {
        pthread_condattr_destroy(&attr);
        Py_DECREF(w);
        PyErr_SetString(PyExc_OSError, "Writer: cannot make its lock");
        return NULL;
    }
    pthread_condattr_destroy(&attr);
    int rc = pthread_create(&w->thread, NULL, writer_main, w);
    if (rc != 0) {
        Py_DECREF(w);
        errno = rc;
        return PyErr_SetFromErrno(PyExc_OSError);
    }
    w->started = 1;
    Py_BEGIN_ALLOW_THREADS /* until it has set `native_id` */
    pthread_mutex_lock(&w->mutex);
    while (!w->ready) {
        pthread_cond_wait(&w->done, &w->mutex);
    }
    pthread_mutex_unlock(&w->mutex);
    Py_END_ALLOW_THREADS
    return (PyObject *)w;
}

/* Stop the thread after what is queued, and wait for it (without the GIL). */
static void
writer_join(Writer *w)
{
    if (!w->started || w->pid != getpid()) {
        return; /* a fork's child: the thread is the parent's, its lock may be held forever */
    }
    if (Py_IsFinalizing()) {
        return; /* the interpreter is going: the thread ends with the process (the exit drained it) */
    }
    pthread_mutex_lock(&w->mutex);
    w->stopping = 1;
    pthread_cond_broadcast(&w->work);
    pthread_mutex_unlock(&w->mutex);
    Py_BEGIN_ALLOW_THREADS
    pthread_join(w->thread, NULL);
    Py_END_ALLOW_THREADS
    w->started = 0;
}

static void
writer_dealloc(Writer *w)
{
    writer_join(w);
    if (w->pid == getpid() && !w->started) {
        for (Job *job = w->head; job != NULL;) {
            Job *next = job->next;
            free(job);
            job = next;
        }
        pthread_mutex_destroy(&w->mutex);
        pthread_cond_destroy(&w->work);
        pthread_cond_destroy(&w->done);
    }
    PyTypeObject *type = Py_TYPE(w);
    type->tp_free((PyObject *)w);
    Py_DECREF(type);
}

static PyObject *
writer_submit(Writer *w, PyObject *const *args, Py_ssize_t nargs)
{
    if (expect_args("submit", nargs, 2) < 0) {
        return NULL;
    }
    void *publisher = PyLong_AsVoidPtr(args[0]);
    if (publisher == NULL) {
        if (!PyErr_Occurred()) {
            PyErr_SetString(PyExc_ValueError, "submit: a NULL publisher");
        }
        return NULL;
    }
    Py_buffer view;
    if (PyObject_GetBuffer(args[1], &view, PyBUF_SIMPLE) < 0) {
        return NULL;
    }
    Job *job = malloc(sizeof(Job) + (size_t)view.len);
    if (job == NULL) {
        PyBuffer_Release(&view);
        return PyErr_NoMemory();
    }
    job->next = NULL;
    job->publisher = publisher;
    job->submitted = monotonic_ns();
    job->size = (size_t)view.len;
    memcpy(job->data, view.buf, (size_t)view.len);
    PyBuffer_Release(&view);
    if (w->pid != getpid() || !w->started) {
        free(job);
        PyErr_SetString(PyExc_RuntimeError, "dbglog's writer thread is stopped (or belongs to the parent process)");
        return NULL;
    }
    pthread_mutex_lock(&w->mutex);
    /* Full: wait for room without the GIL (the calling threads keep queueing into the pipe), at most
     * `full_wait`. The mutex is never held while the GIL is awaited: a thread holding the GIL may be
     * waiting for the mutex. */
#define FULL (w->queued_bytes != 0 && w->queued_bytes + job->size > w->capacity && !w->stopping)
    if (FULL && !w->refusing) {
        struct timespec until = deadline_in(w->full_wait);
        int rc = 0;
        pthread_mutex_unlock(&w->mutex);
        Py_BEGIN_ALLOW_THREADS
        pthread_mutex_lock(&w->mutex);
        while (FULL && rc != ETIMEDOUT) {
            rc = pthread_cond_timedwait(&w->done, &w->mutex, &until);
        }
        pthread_mutex_unlock(&w->mutex);
        Py_END_ALLOW_THREADS
        pthread_mutex_lock(&w->mutex);
    }
    if (FULL) {
        w->refusing = 1;
        size_t queued = w->queued_bytes;
        pthread_mutex_unlock(&w->mutex);
        free(job);
        PyErr_Format(PyExc_BufferError,
                     "dbglog's writer thread still holds %zu bytes of messages it could not write", queued);
        return NULL;
    }
#undef FULL
    if (w->stopping) {
        pthread_mutex_unlock(&w->mutex);
        free(job);
        PyErr_SetString(PyExc_RuntimeError, "dbglog's writer thread is stopped");
        return NULL;
    }
    if (w->tail != NULL) {
        w->tail->next = job;
    }
    else {
        w->head = job;
    }
    w->tail = job;
    w->queued_bytes += job->size;
    pthread_cond_signal(&w->work);
    pthread_mutex_unlock(&w->mutex);
    Py_RETURN_NONE;
}

static PyObject *
writer_drain(Writer *w, PyObject *const *args, Py_ssize_t nargs)
{
    if (expect_args("drain", nargs, 1) < 0) {
        return NULL;
    }
    double timeout = PyFloat_AsDouble(args[0]);
    if (timeout == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    if (w->pid != getpid() || !w->started) {
        Py_RETURN_TRUE; /* nothing of this process's is being written */
    }
    int idle;
    Py_BEGIN_ALLOW_THREADS
    struct timespec until = deadline_in(timeout);
    pthread_mutex_lock(&w->mutex);
    int rc = 0;
    while ((w->head != NULL || w->busy) && rc != ETIMEDOUT) {
        rc = pthread_cond_timedwait(&w->done, &w->mutex, &until);
    }
    idle = w->head == NULL && !w->busy;
    pthread_mutex_unlock(&w->mutex);
    Py_END_ALLOW_THREADS
    return PyBool_FromLong(idle);
}

static PyObject *
writer_discard(Writer *w, PyObject *Py_UNUSED(ignored))
{
    if (w->pid != getpid() || !w->started) {
        return PyLong_FromLong(0);
    }
    pthread_mutex_lock(&w->mutex);
    Job *job = w->head;
    w->head = w->tail = NULL;
    long n = 0;
    while (job != NULL) {
        Job *next = job->next;
        w->queued_bytes -= job->size;
        free(job);
        job = next;
        n++;
    }
    pthread_cond_broadcast(&w->done);
    pthread_mutex_unlock(&w->mutex);
    return PyLong_FromLong(n);
}

static PyObject *
writer_stop(Writer *w, PyObject *Py_UNUSED(ignored))
{
    writer_join(w);
    Py_RETURN_NONE;
}

static PyObject *
writer_stats(Writer *w, PyObject *Py_UNUSED(ignored))
{
    unsigned long long written = 0, failed = 0;
    Py_ssize_t queued = 0;
    int busy = 0;
    double waiting = 0.0;
    if (w->pid == getpid()) {
        pthread_mutex_lock(&w->mutex);
        written = w->written;
        failed = w->failed;
        queued = (Py_ssize_t)w->queued_bytes;
        busy = w->busy;
        int64_t oldest = busy ? w->busy_submitted : (w->head != NULL ? w->head->submitted : 0);
        int64_t longest = w->longest_ns;
        w->longest_ns = 0;
        pthread_mutex_unlock(&w->mutex);
        int64_t now_waiting = oldest ? monotonic_ns() - oldest : 0;
        waiting = (double)(now_waiting > longest ? now_waiting : longest) / 1e9;
    }
    return Py_BuildValue("{sKsKsnsOsd}", "written", written, "failed", failed, "queued_bytes", queued, "busy",
                         busy ? Py_True : Py_False, "longest_wait_s", waiting);
}

static PyMethodDef writer_methods[] = {
    {"submit", (PyCFunction)(void (*)(void))writer_submit, METH_FASTCALL,
     "submit(publisher, data): queue a copy of `data` for the rcl publisher at that address. While "
     "`capacity` bytes are queued it waits without the GIL, at most `full_wait` s, then raises "
     "BufferError (at once until a message is written). Raises RuntimeError once stopped."},
    {"drain", (PyCFunction)(void (*)(void))writer_drain, METH_FASTCALL,
     "drain(timeout) -> bool: wait until everything submitted is written; False when `timeout` ran out."},
    {"discard", (PyCFunction)writer_discard, METH_NOARGS,
     "discard() -> int: drop what is queued and not yet being written; how many messages."},
    {"stop", (PyCFunction)writer_stop, METH_NOARGS, "stop(): write what is queued, then end the thread."},
    {"stats", (PyCFunction)writer_stats, METH_NOARGS,
     "stats() -> dict: messages written and refused by rcl, bytes queued, whether one is being written, "
     "and the longest a message waited to be written since the last look: one written since then, or the "
     "oldest still waiting (s)."},
    {NULL, NULL, 0, NULL},
};

static PyObject *
writer_native_id(Writer *w, void *Py_UNUSED(closure))
{
    return PyLong_FromLong(w->native_id); /* set before `ready` */
}

static PyGetSetDef writer_getset[] = {
    {"native_id", (getter)writer_native_id, NULL, "The writer thread's id (as threading.get_native_id).", NULL},
    {NULL},
};

static PyType_Slot writer_slots[] = {
    {Py_tp_new, writer_new},
    {Py_tp_dealloc, writer_dealloc},
    {Py_tp_methods, writer_methods},
    {Py_tp_getset, writer_getset},
    {Py_tp_doc, "Writer(publish, reset, capacity, full_wait=1.0): a thread that writes serialized messages "
                "with rcl, in order, without the GIL."},
    {0, NULL},
};

static PyType_Spec writer_spec = {
    .name = "dbglog.api._hot.Writer",
    .basicsize = sizeof(Writer),
    .flags = Py_TPFLAGS_DEFAULT,
    .slots = writer_slots,
};

int
writer_add_type(PyObject *module)
{
    PyObject *type = PyType_FromModuleAndSpec(module, &writer_spec, NULL);
    if (type == NULL) {
        return -1;
    }
    int rc = PyModule_AddObjectRef(module, "Writer", type);
    Py_DECREF(type);
    return rc;
}
