/* The compiled hot path of logfloat/logint/logbool/logstring (see _hot.pyi and docs/api.md), and the
 * switched-off functions' plain call (NoOp, at the end).
 *
 * A HotCall wraps one of those Python functions. A call to a known tag with a value of the exact
 * builtin type, no options or only a float `throttle` that holds the call back, does in C what the
 * Python function's own fast path does: count the call, append (channel, value, source time) to the
 * queue, wake the publisher thread if it sleeps; or count a throttled call as rate-limited. Anything
 * else (a new tag, another type, an option, an error of any kind) calls the Python function with the
 * same arguments, which decides and reports as it always did. The C path never raises.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <frameobject.h>
#include <structmember.h>
#if PY_VERSION_HEX >= 0x030B0000 && PY_VERSION_HEX < 0x030D0000
/* 3.11 and 3.12: the caller's code object and instruction read from its interpreter frame, without
 * materializing a frame object (an allocation, and a copy of the frame when the caller returns). The
 * layout comes from this very interpreter's headers; other versions use the public PyEval_GetFrame. */
#define HOT_INTERNAL_FRAME 1
#ifndef Py_BUILD_CORE
#define Py_BUILD_CORE 1
#endif
#include <internal/pycore_frame.h>
#undef Py_BUILD_CORE
#endif
#include <math.h>
#include <string.h>
#include <time.h>

#include "_parts.h"

enum { KIND_FLOAT = 0, KIND_INT = 1, KIND_BOOL = 2, KIND_STR = 3 };

/* An attribute read (and written) straight in its object's slot when the object is exactly of the type
 * whose ``__slots__`` hold it, as CPython's own attribute specialization does; otherwise, or when the
 * attribute is not such a slot, through PyObject_GetAttr/SetAttr. The generic lookup's code and the type's
 * method cache are cold at a loop's first call: this is a type check and a load. */
typedef struct {
    PyTypeObject *type; /* strong; NULL: the generic path only */
    Py_ssize_t offset;
    PyObject *name;     /* interned, module-lifetime */
} Slot;

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *dict;        /* __dict__: functools.update_wrapper copies the name, doc, __wrapped__ */
    PyObject *slow;        /* the Python function: everything the C path does not decide */
    PyObject *table;       /* dict: tag as given -> channel */
    PyObject *append;      /* the queue's bound append */
    PyObject *queue;       /* the deque itself (its length) */
    PyObject *pipe;        /* .capacity, .sleeping, .wake() */
    PyObject *calls;       /* itertools.count: the calls counter */
    PyObject *rate_limited;/* itertools.count: the rate-limited counter */
    PyObject *clock;       /* the rate limiter's clock (time.monotonic) */
    Slot capacity, sleeping; /* the pipe's */
    Slot rate_site;          /* a channel's */
    Slot last_pass, site_calls; /* a call site's rate state */
    int kind;
    int monotonic;         /* the clock is time.monotonic: read CLOCK_MONOTONIC here */
    Py_ssize_t max_chars;  /* logstring: longer texts take the Python path (it cuts them) */
} HotCall;

static PyObject *one;
static PyObject *s_capacity, *s_sleeping, *s_wake, *s_rate_site, *s_last_pass, *s_calls, *s_throttle;

static int
hot_traverse(HotCall *self, visitproc visit, void *arg)
{
    Py_VISIT(self->dict);
    Py_VISIT(self->slow);
    Py_VISIT(self->table);
    Py_VISIT(self->append);
    Py_VISIT(self->queue);
    Py_VISIT(self->pipe);
    Py_VISIT(self->calls);
    Py_VISIT(self->rate_limited);
    Py_VISIT(self->clock);
    Py_VISIT(self->capacity.type);
    Py_VISIT(self->sleeping.type);
    Py_VISIT(self->rate_site.type);
    Py_VISIT(self->last_pass.type);
    Py_VISIT(self->site_calls.type);
    return 0;
}

static int
hot_clear(HotCall *self)
{
    Py_CLEAR(self->dict);
    Py_CLEAR(self->slow);
    Py_CLEAR(self->table);
    Py_CLEAR(self->append);
    Py_CLEAR(self->queue);
    Py_CLEAR(self->pipe);
    Py_CLEAR(self->calls);
    Py_CLEAR(self->rate_limited);
    Py_CLEAR(self->clock);
    Py_CLEAR(self->capacity.type);
    Py_CLEAR(self->sleeping.type);
    Py_CLEAR(self->rate_site.type);
    Py_CLEAR(self->last_pass.type);
    Py_CLEAR(self->site_calls.type);
    return 0;
}

static void
hot_dealloc(HotCall *self)
{
    PyObject_GC_UnTrack(self);
    hot_clear(self);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* Advance an itertools.count by one (the counters' increment); 0, or -1 with an exception set. */
static int
count_one(PyObject *counter)
{
    PyObject *n = Py_TYPE(counter)->tp_iternext(counter);
    if (n == NULL) {
        if (!PyErr_Occurred()) {
            PyErr_SetString(PyExc_RuntimeError, "dbglog: a counter ended");
        }
        return -1;
    }
    Py_DECREF(n);
    return 0;
}

/* Find `name` as an object slot of `type` (None or anything else: the generic path). */
static void
slot_find(Slot *slot, PyObject *type, PyObject *name)
{
    slot->type = NULL;
    slot->offset = 0;
    slot->name = name;
    if (type == NULL || !PyType_Check(type)) {
        return;
    }
    PyObject *descr = PyObject_GetAttr(type, name); /* on a class, a slot's member descriptor itself */
    if (descr == NULL) {
        PyErr_Clear();
        return;
    }
    if (Py_IS_TYPE(descr, &PyMemberDescr_Type)) {
        PyMemberDef *member = ((PyMemberDescrObject *)descr)->d_member;
        if (member->type == T_OBJECT_EX && member->offset > 0) {
            slot->type = (PyTypeObject *)Py_NewRef(type);
            slot->offset = member->offset;
        }
    }
    Py_DECREF(descr);
}

/* `obj`'s attribute (a new reference), or NULL with an exception set. */
static PyObject *
slot_get(const Slot *slot, PyObject *obj)
{
    if (slot->type != NULL && Py_TYPE(obj) == slot->type) {
        PyObject *value = *(PyObject **)((char *)obj + slot->offset);
        if (value == NULL) {
            PyErr_SetObject(PyExc_AttributeError, slot->name);
            return NULL;
        }
        return Py_NewRef(value);
    }
    return PyObject_GetAttr(obj, slot->name);
}

/* Set `obj`'s attribute to `value`: 0, or -1 with an exception set. */
static int
slot_set(const Slot *slot, PyObject *obj, PyObject *value)
{
    if (slot->type != NULL && Py_TYPE(obj) == slot->type) {
        PyObject **where = (PyObject **)((char *)obj + slot->offset);
        PyObject *old = *where;
        *where = Py_NewRef(value);
        Py_XDECREF(old);
        return 0;
    }
    return PyObject_SetAttr(obj, slot->name, value);
}

/* 1 when `value` is what this function queues without a check in Python, 0 otherwise. */
static int
value_fits(HotCall *self, PyObject *value)
{
    switch (self->kind) {
    case KIND_FLOAT:
        return PyFloat_CheckExact(value);
    case KIND_INT: {
        if (!PyLong_CheckExact(value)) {
            return 0;
        }
        int overflow = 0;
        long long v = PyLong_AsLongLongAndOverflow(value, &overflow);
        if (v == -1 && PyErr_Occurred()) {
            PyErr_Clear();
            return 0;
        }
        return overflow == 0;
    }
    case KIND_BOOL:
        return PyBool_Check(value);
    case KIND_STR:
        if (!PyUnicode_CheckExact(value) || !PyUnicode_IS_ASCII(value)) {
            return 0;
        }
        Py_ssize_t n = PyUnicode_GET_LENGTH(value);
        return n <= self->max_chars && memchr(PyUnicode_DATA(value), 0, (size_t)n) == NULL;
    }
    return 0;
}

/* An attribute as a truth value: 1, 0, or -1 with an exception set. */
static int
slot_true(const Slot *slot, PyObject *obj)
{
    PyObject *v = slot_get(slot, obj);
    if (v == NULL) {
        return -1;
    }
    int truth = v == Py_True ? 1 : (v == Py_False ? 0 : PyObject_IsTrue(v));
    Py_DECREF(v);
    return truth;
}

/* Append (channel, value, now), count the call and wake the thread if it sleeps. 0; -1 with an exception
 * set when nothing was queued (the Python function then takes the call); a failure after the append (the
 * count, the wake) is cleared: the sample is queued, and the next call wakes the thread. */
static int
enqueue(HotCall *self, PyObject *ch, PyObject *value)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0) {
        PyErr_SetFromErrno(PyExc_OSError);
        return -1;
    }
    PyObject *stamp = PyLong_FromLongLong((long long)ts.tv_sec * 1000000000LL + ts.tv_nsec);
    if (stamp == NULL) {
        return -1;
    }
    PyObject *item = PyTuple_New(3);
    if (item == NULL) {
        Py_DECREF(stamp);
        return -1;
    }
    Py_INCREF(ch);
    Py_INCREF(value);
    PyTuple_SET_ITEM(item, 0, ch);
    PyTuple_SET_ITEM(item, 1, value);
    PyTuple_SET_ITEM(item, 2, stamp);
    PyObject *done = PyObject_CallOneArg(self->append, item);
    Py_DECREF(item);
    if (done == NULL) {
        return -1;
    }
    Py_DECREF(done);
    int sleeping = count_one(self->calls) < 0 ? -1 : slot_true(&self->sleeping, self->pipe);
    if (sleeping > 0) {
        PyObject *woke = PyObject_CallMethodNoArgs(self->pipe, s_wake);
        Py_XDECREF(woke);
    }
    if (PyErr_Occurred()) {
        PyErr_Clear();
    }
    return 0;
}

/* The code object (borrowed, compared by identity only) and instruction offset (as frame.f_lasti) of
 * the Python code that called this function: 1, or 0 when there is none. */
static int
caller_site(PyObject **code, long *lasti)
{
#ifdef HOT_INTERNAL_FRAME
    _PyInterpreterFrame *frame = PyThreadState_GET()->cframe->current_frame;
    while (frame != NULL && _PyFrame_IsIncomplete(frame)) {
        frame = frame->previous;
    }
    if (frame == NULL) {
        return 0;
    }
    int index = _PyInterpreterFrame_LASTI(frame);
    *code = (PyObject *)frame->f_code;
    *lasti = index < 0 ? -1 : (long)index * (long)sizeof(_Py_CODEUNIT);
    return 1;
#else
    PyFrameObject *frame = PyEval_GetFrame(); /* borrowed */
    if (frame == NULL) {
        return 0;
    }
    PyCodeObject *frame_code = PyFrame_GetCode(frame);
    *code = (PyObject *)frame_code; /* the frame keeps it alive during this call */
    Py_DECREF(frame_code);
    *lasti = PyFrame_GetLasti(frame);
    return 1;
#endif
}

/* The rate limiter's clock into `now`: time.monotonic read in C when that is the clock, else a call.
 * 1; 0 when it gave no float; -1 with an exception set. */
static int
clock_now(HotCall *self, double *now)
{
    if (self->monotonic) {
        struct timespec ts;
        if (clock_gettime(CLOCK_MONOTONIC, &ts) == 0) {
            *now = (double)((long long)ts.tv_sec * 1000000000LL + ts.tv_nsec) / 1e9;
            return 1;
        }
    }
    PyObject *value = PyObject_CallNoArgs(self->clock);
    if (value == NULL) {
        return -1;
    }
    int ok = PyFloat_CheckExact(value);
    if (ok) {
        *now = PyFloat_AS_DOUBLE(value);
    }
    Py_DECREF(value);
    return ok;
}

/* A throttled call from the instruction that last rate-controlled the tag, within its period: count it
 * as rate-limited and return 1; 0 when the Python path must decide (an error too: it is cleared, and
 * nothing was counted). */
static int
held_back(HotCall *self, PyObject *ch, PyObject *throttle)
{
    double period = PyFloat_AS_DOUBLE(throttle);
    if (!(period < INFINITY)) {
        return 0;
    }
    PyObject *code;
    long lasti;
    if (!caller_site(&code, &lasti)) {
        return 0;
    }
    PyObject *known = slot_get(&self->rate_site, ch);
    if (known == NULL) {
        PyErr_Clear();
        return 0;
    }
    int result = 0;
    if (PyTuple_CheckExact(known) && PyTuple_GET_SIZE(known) >= 3 && code == PyTuple_GET_ITEM(known, 0)) {
        long known_lasti = PyLong_AsLong(PyTuple_GET_ITEM(known, 1));
        if (known_lasti == -1 && PyErr_Occurred()) {
            PyErr_Clear();
        } else if (known_lasti == lasti) {
            result = 2; /* the same instruction: compare the time */
        }
    }
    if (result != 2) {
        Py_DECREF(known);
        return 0;
    }
    PyObject *state = PyTuple_GET_ITEM(known, 2);
    Py_INCREF(state);
    Py_DECREF(known);
    result = 0;
    PyObject *last = slot_get(&self->last_pass, state);
    double now = 0.0;
    int timed = last == NULL ? -1 : clock_now(self, &now);
    if (timed > 0 && PyFloat_CheckExact(last) && now - PyFloat_AS_DOUBLE(last) < period) {
        PyObject *calls = slot_get(&self->site_calls, state);
        PyObject *more = calls == NULL ? NULL : PyNumber_Add(calls, one);
        if (more != NULL && slot_set(&self->site_calls, state, more) == 0) {
            /* Counted from here on: the call ends here whatever happens next. */
            result = 1;
            if (count_one(self->calls) < 0 || count_one(self->rate_limited) < 0) {
                PyErr_Clear();
            }
        }
        Py_XDECREF(calls);
        Py_XDECREF(more);
    }
    if (PyErr_Occurred()) {
        PyErr_Clear();
    }
    Py_XDECREF(last);
    Py_DECREF(state);
    return result;
}

static PyObject *
hot_vectorcall(HotCall *self, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    PyObject *throttle = NULL;
    if (nargs != 2) {
        goto slow;
    }
    if (kwnames != NULL && PyTuple_GET_SIZE(kwnames) != 0) {
        if (PyTuple_GET_SIZE(kwnames) != 1) {
            goto slow;
        }
        PyObject *name = PyTuple_GET_ITEM(kwnames, 0);
        if (name != s_throttle && PyUnicode_Compare(name, s_throttle) != 0) {
            if (PyErr_Occurred()) {
                PyErr_Clear();
            }
            goto slow;
        }
        throttle = args[2];
        if (!PyFloat_CheckExact(throttle)) {
            goto slow;
        }
    }
    PyObject *tag = args[0], *value = args[1];
    if (!value_fits(self, value)) {
        goto slow;
    }
    PyObject *ch = PyDict_GetItemWithError(self->table, tag); /* borrowed */
    if (ch == NULL) {
        if (PyErr_Occurred()) { /* an unhashable tag: the Python path reports it */
            PyErr_Clear();
        }
        goto slow;
    }
    Py_INCREF(ch);
    if (throttle != NULL) {
        /* Held back before the queue is looked at (the queue and the pipe are what the publisher thread
         * writes: cache lines another core holds). A full queue changes nothing here: the Python path
         * counts a held-back call as rate-limited too. */
        int held = held_back(self, ch, throttle);
        Py_DECREF(ch);
        if (!held) {
            goto slow;
        }
        Py_RETURN_NONE;
    }
    PyObject *cap = slot_get(&self->capacity, self->pipe);
    if (cap == NULL) {
        Py_DECREF(ch);
        PyErr_Clear();
        goto slow;
    }
    Py_ssize_t capacity = PyLong_AsSsize_t(cap);
    Py_DECREF(cap);
    Py_ssize_t queued = PyObject_Length(self->queue);
    if (PyErr_Occurred() || queued < 0 || queued >= capacity) {
        Py_DECREF(ch);
        PyErr_Clear();
        goto slow;
    }
    int status = enqueue(self, ch, value);
    Py_DECREF(ch);
    if (status < 0) { /* nothing queued, nothing counted: the Python function takes the call */
        PyErr_Clear();
        goto slow;
    }
    Py_RETURN_NONE;
slow:
    return PyObject_Vectorcall(self->slow, args, nargsf, kwnames);
}

static PyObject *
hot_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    static char *names[] = {"slow",  "kind",         "table", "queue",     "pipe",         "calls",
                            "rate_limited", "clock", "max_chars", "channel_type", "site_type", NULL};
    PyObject *slow, *table, *queue, *pipe, *calls, *rate_limited, *clock;
    PyObject *channel_type = NULL, *site_type = NULL;
    int kind;
    Py_ssize_t max_chars;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OiO!OOOOOn|$OO:HotCall", names, &slow, &kind, &PyDict_Type,
                                     &table, &queue, &pipe, &calls, &rate_limited, &clock, &max_chars,
                                     &channel_type, &site_type)) {
        return NULL;
    }
    if (kind < KIND_FLOAT || kind > KIND_STR) {
        PyErr_Format(PyExc_ValueError, "HotCall: kind must be 0-3, not %d", kind);
        return NULL;
    }
    if (!PyIter_Check(calls) || !PyIter_Check(rate_limited)) {
        PyErr_SetString(PyExc_TypeError, "HotCall: calls and rate_limited must be iterators (counters)");
        return NULL;
    }
    PyObject *append = PyObject_GetAttrString(queue, "append");
    if (append == NULL) {
        return NULL;
    }
    HotCall *self = (HotCall *)type->tp_alloc(type, 0);
    if (self == NULL) {
        Py_DECREF(append);
        return NULL;
    }
    self->vectorcall = (vectorcallfunc)hot_vectorcall;
    self->dict = NULL;
    self->slow = Py_NewRef(slow);
    self->table = Py_NewRef(table);
    self->append = append;
    self->queue = Py_NewRef(queue);
    self->pipe = Py_NewRef(pipe);
    self->calls = Py_NewRef(calls);
    self->rate_limited = Py_NewRef(rate_limited);
    self->clock = Py_NewRef(clock);
    self->kind = kind;
    self->max_chars = max_chars;
    self->monotonic = 0;
    slot_find(&self->capacity, (PyObject *)Py_TYPE(pipe), s_capacity);
    slot_find(&self->sleeping, (PyObject *)Py_TYPE(pipe), s_sleeping);
    slot_find(&self->rate_site, channel_type, s_rate_site);
    slot_find(&self->last_pass, site_type, s_last_pass);
    slot_find(&self->site_calls, site_type, s_calls);
    PyObject *time_module = PyImport_ImportModule("time");
    PyObject *monotonic = time_module == NULL ? NULL : PyObject_GetAttrString(time_module, "monotonic");
    Py_XDECREF(time_module);
    if (monotonic == NULL) {
        Py_DECREF(self);
        return NULL;
    }
    self->monotonic = monotonic == clock;
    Py_DECREF(monotonic);
    return (PyObject *)self;
}

static PyMemberDef hot_members[] = {
    {"__dictoffset__", T_PYSSIZET, offsetof(HotCall, dict), READONLY, NULL},
    {"__vectorcalloffset__", T_PYSSIZET, offsetof(HotCall, vectorcall), READONLY, NULL},
    {"slow", T_OBJECT_EX, offsetof(HotCall, slow), READONLY, "the Python function this call falls back to"},
    {NULL},
};

static PyGetSetDef hot_getset[] = {
    {"__dict__", PyObject_GenericGetDict, PyObject_GenericSetDict, NULL, NULL},
    {NULL},
};

static PyType_Slot hot_slots[] = {
    {Py_tp_doc, "A logging function whose common case runs in C (the Python function decides the rest)."},
    {Py_tp_new, hot_new},
    {Py_tp_dealloc, hot_dealloc},
    {Py_tp_traverse, hot_traverse},
    {Py_tp_clear, hot_clear},
    {Py_tp_call, PyVectorcall_Call}, /* every call, however made, takes the vectorcall above */
    {Py_tp_members, hot_members},
    {Py_tp_getset, hot_getset},
    {0, NULL},
};

static PyType_Spec hot_spec = {
    .name = "dbglog.api._hot.HotCall",
    .basicsize = sizeof(HotCall),
    .flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_IMMUTABLETYPE,
    .slots = hot_slots,
};

/* ----- NoOp: a switched-off logging function ---------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *dict;
    PyObject *slow;          /* the Python no-op: every other call shape (it refuses what is refused on) */
    PyObject *options;       /* tuple of the keyword-only option names (interned) */
    Py_ssize_t positional;   /* the call that returns here: exactly this many positional arguments... */
} NoOp;                      /* ...and keywords among `options` only */

static int
noop_traverse(NoOp *self, visitproc visit, void *arg)
{
    Py_VISIT(self->dict);
    Py_VISIT(self->slow);
    Py_VISIT(self->options);
    return 0;
}

static int
noop_clear(NoOp *self)
{
    Py_CLEAR(self->dict);
    Py_CLEAR(self->slow);
    Py_CLEAR(self->options);
    return 0;
}

static void
noop_dealloc(NoOp *self)
{
    PyObject_GC_UnTrack(self);
    noop_clear(self);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *
noop_vectorcall(NoOp *self, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    if (PyVectorcall_NARGS(nargsf) != self->positional) {
        return PyObject_Vectorcall(self->slow, args, nargsf, kwnames);
    }
    Py_ssize_t nkw = kwnames == NULL ? 0 : PyTuple_GET_SIZE(kwnames);
    Py_ssize_t nopt = PyTuple_GET_SIZE(self->options);
    for (Py_ssize_t i = 0; i < nkw; i++) { /* keyword names are interned: compared by identity */
        PyObject *name = PyTuple_GET_ITEM(kwnames, i);
        Py_ssize_t j = 0;
        while (j < nopt && PyTuple_GET_ITEM(self->options, j) != name) {
            j++;
        }
        if (j == nopt) { /* not an option, or a name not interned: the Python no-op decides */
            return PyObject_Vectorcall(self->slow, args, nargsf, kwnames);
        }
    }
    Py_RETURN_NONE;
}

static PyObject *
noop_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    static char *names[] = {"slow", "positional", "options", NULL};
    PyObject *slow, *options;
    Py_ssize_t positional;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OnO!:NoOp", names, &slow, &positional, &PyTuple_Type,
                                     &options)) {
        return NULL;
    }
    for (Py_ssize_t i = 0; i < PyTuple_GET_SIZE(options); i++) {
        if (!PyUnicode_CheckExact(PyTuple_GET_ITEM(options, i))) {
            PyErr_SetString(PyExc_TypeError, "NoOp: options must be a tuple of str");
            return NULL;
        }
    }
    if (!PyCallable_Check(slow) || positional < 0) {
        PyErr_SetString(PyExc_TypeError, "NoOp: slow must be callable and positional >= 0");
        return NULL;
    }
    NoOp *self = (NoOp *)type->tp_alloc(type, 0);
    if (self == NULL) {
        return NULL;
    }
    self->vectorcall = (vectorcallfunc)noop_vectorcall;
    self->dict = NULL;
    self->slow = Py_NewRef(slow);
    self->positional = positional;
    self->options = PyTuple_New(PyTuple_GET_SIZE(options));
    if (self->options == NULL) {
        Py_DECREF(self);
        return NULL;
    }
    for (Py_ssize_t i = 0; i < PyTuple_GET_SIZE(options); i++) {
        PyObject *name = Py_NewRef(PyTuple_GET_ITEM(options, i));
        PyUnicode_InternInPlace(&name);
        PyTuple_SET_ITEM(self->options, i, name);
    }
    return (PyObject *)self;
}

static PyMemberDef noop_members[] = {
    {"__dictoffset__", T_PYSSIZET, offsetof(NoOp, dict), READONLY, NULL},
    {"__vectorcalloffset__", T_PYSSIZET, offsetof(NoOp, vectorcall), READONLY, NULL},
    {"slow", T_OBJECT_EX, offsetof(NoOp, slow), READONLY, "the Python no-op this one falls back to"},
    {NULL},
};

static PyType_Slot noop_slots[] = {
    {Py_tp_doc, "A switched-off logging function: a call with its positional arguments and keyword options "
                "returns at once, any other shape goes to the Python no-op (which refuses what the "
                "switched-on function refuses)."},
    {Py_tp_new, noop_new},
    {Py_tp_dealloc, noop_dealloc},
    {Py_tp_traverse, noop_traverse},
    {Py_tp_clear, noop_clear},
    {Py_tp_call, PyVectorcall_Call},
    {Py_tp_members, noop_members},
    {Py_tp_getset, hot_getset},
    {0, NULL},
};

static PyType_Spec noop_spec = {
    .name = "dbglog.api._hot.NoOp",
    .basicsize = sizeof(NoOp),
    .flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_IMMUTABLETYPE,
    .slots = noop_slots,
};

static int
hot_exec(PyObject *module)
{
#define INTERN(var, text)                                                                                    \
    if ((var = PyUnicode_InternFromString(text)) == NULL) {                                                 \
        return -1;                                                                                           \
    }
    INTERN(s_capacity, "capacity");
    INTERN(s_sleeping, "sleeping");
    INTERN(s_wake, "wake");
    INTERN(s_rate_site, "rate_site");
    INTERN(s_last_pass, "last_pass");
    INTERN(s_calls, "calls");
    INTERN(s_throttle, "throttle");
    if ((one = PyLong_FromLong(1)) == NULL || flush_init() < 0 || writer_add_type(module) < 0) {
        return -1;
    }
#undef INTERN
    PyObject *type = PyType_FromModuleAndSpec(module, &hot_spec, NULL);
    if (type == NULL) {
        return -1;
    }
    int rc = PyModule_AddObjectRef(module, "HotCall", type);
    Py_DECREF(type);
    if (rc < 0) {
        return -1;
    }
    type = PyType_FromModuleAndSpec(module, &noop_spec, NULL);
    if (type == NULL) {
        return -1;
    }
    rc = PyModule_AddObjectRef(module, "NoOp", type);
    Py_DECREF(type);
    return rc;
}

static PyModuleDef_Slot hot_module_slots[] = {
    {Py_mod_exec, hot_exec},
    {0, NULL},
};

static struct PyModuleDef hot_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "dbglog.api._hot",
    .m_doc = "The compiled hot path of dbglog's scalar logging functions, its switched-off no-ops, and the "
             "publisher thread's per-sample work (_flush.c).",
    .m_size = 0,
    .m_methods = flush_methods,
    .m_slots = hot_module_slots,
};

PyMODINIT_FUNC
PyInit__hot(void)
{
    return PyModuleDef_Init(&hot_module);
}
