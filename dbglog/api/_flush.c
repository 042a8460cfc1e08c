/* The publisher thread's per-sample work in C (see _hot.pyi and docs/api.md, "The flush in C").
 *
 * `take` pops up to `limit` queued (channel, value, source time) samples into a list. `pack_batch`
 * groups them by channel (first seen first) and builds the whole batch message: the CDR bytes of a
 * std_msgs/UInt8MultiArray holding dbglog/_ros/_batch.py's version-2 layout, the same bytes that
 * module's `encode_batch` returns for the same samples. dbglog/api/_pipe.py holds the Python version of
 * both (`take_items`, `pack_batch`), which runs without the compiled module; tests/test_flush_c.py holds
 * the two to the same results, byte for byte. A sample's channel gives its type code (`code`: 0-11,
 * `SCALAR_TYPES` order) and its tag (`tag_bytes`).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "_parts.h"

enum { CODE_FLOAT32 = 1, CODE_LAST_SIGNED = 5, CODE_STRING = 11, N_CODES = 12 };
enum { BREATHE_EVERY = 256 };   /* samples between two looks at the clock */
static const long BREATHE_SLEEP_NS = 10000; /* the GIL let go this long (as _pipe._YIELD_S) */

static PyObject *s_popleft, *s_code, *s_tag_bytes;

int
flush_init(void)
{
    if ((s_popleft = PyUnicode_InternFromString("popleft")) == NULL
        || (s_code = PyUnicode_InternFromString("code")) == NULL
        || (s_tag_bytes = PyUnicode_InternFromString("tag_bytes")) == NULL) {
        return -1;
    }
    return 0;
}

/* Let other threads take the GIL if this one has held it `limit` ns since *mark (0: never). */
static void
breathe(int64_t *mark, int64_t limit)
{
    if (limit <= 0) {
        return;
    }
    int64_t now = monotonic_ns();
    if (now - *mark <= limit) {
        return;
    }
    struct timespec pause = {0, BREATHE_SLEEP_NS};
    Py_BEGIN_ALLOW_THREADS
    nanosleep(&pause, NULL);
    Py_END_ALLOW_THREADS
    *mark = monotonic_ns();
}

static PyObject *
take(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (expect_args("take", nargs, 2) < 0) {
        return NULL;
    }
    Py_ssize_t limit = PyLong_AsSsize_t(args[1]);
    if (limit == -1 && PyErr_Occurred()) {
        return NULL;
    }
    Py_ssize_t n = PyObject_Length(args[0]);
    if (n < 0) {
        return NULL;
    }
    if (n > limit) {
        n = limit < 0 ? 0 : limit;
    }
    PyObject *items = PyList_New(0);
    if (items == NULL || n == 0) {
        return items;
    }
    PyObject *popleft = PyObject_GetAttr(args[0], s_popleft);
    if (popleft == NULL) {
        Py_DECREF(items);
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PyObject_CallNoArgs(popleft);
        if (item == NULL) {
            if (PyErr_ExceptionMatches(PyExc_IndexError)) { /* emptied meanwhile (a reset) */
                PyErr_Clear();
                break;
            }
            Py_DECREF(popleft);
            Py_DECREF(items);
            return NULL;
        }
        int rc = PyList_Append(items, item);
        Py_DECREF(item);
        if (rc < 0) { /* the item is lost only if memory ran out */
            Py_DECREF(popleft);
            Py_DECREF(items);
            return NULL;
        }
    }
    Py_DECREF(popleft);
    return items;
}

/* One channel of the batch: its type code and tag (strong). */
typedef struct {
    int code;
    PyObject *tag; /* bytes */
} Tag;

/* One String sample's UTF-8 text: in the str itself (ASCII) or in `owner` (bytes). */
typedef struct {
    const char *data;
    Py_ssize_t size;
} Text;

static inline void
put16(char *p, uint16_t v)
{
    p[0] = (char)v;
    p[1] = (char)(v >> 8);
}

static inline void
put32(char *p, uint32_t v)
{
    for (int k = 0; k < 4; k++) {
        p[k] = (char)(v >> (8 * k));
    }
}

static inline void
put64(char *p, uint64_t v)
{
    for (int k = 0; k < 8; k++) {
        p[k] = (char)(v >> (8 * k));
    }
}

static inline Py_ssize_t
pad8(Py_ssize_t n)
{
    return (8 - n % 8) % 8;
}

/* A sample's 8-byte value slot as its type code says; -1 with an exception when it does not fit. */
static int
slot_bits(PyObject *value, int code, uint64_t *out)
{
    if (code <= CODE_FLOAT32) {
        double d = PyFloat_CheckExact(value) ? PyFloat_AS_DOUBLE(value) : PyFloat_AsDouble(value);
        if (d == -1.0 && PyErr_Occurred()) {
            return -1;
        }
        if (code == CODE_FLOAT32) { /* rounded as the tag's Float32 message holds it */
            float f = (float)d;
            if (isinf(f) && !isinf(d)) {
                PyErr_SetString(PyExc_OverflowError, "float too large to pack with f format");
                return -1;
            }
            d = (double)f;
        }
        memcpy(out, &d, sizeof d);
        return 0;
    }
    PyObject *number = PyLong_Check(value) ? Py_NewRef(value) : PyNumber_Index(value);
    if (number == NULL) {
        return -1;
    }
    if (code <= CODE_LAST_SIGNED) {
        long long v = PyLong_AsLongLong(number);
        Py_DECREF(number);
        if (v == -1 && PyErr_Occurred()) {
            return -1;
        }
        *out = (uint64_t)v;
        return 0;
    }
    unsigned long long v = PyLong_AsUnsignedLongLong(number);
    Py_DECREF(number);
    if (v == (unsigned long long)-1 && PyErr_Occurred()) {
        return -1;
    }
    *out = (uint64_t)v;
    return 0;
}

/* Open addressing on the channel's address: the sample's tag position, or -1 for a new channel. */
typedef struct {
    PyObject *key;
    Py_ssize_t index;
} Entry;

static Py_ssize_t
lookup(Entry *table, size_t mask, PyObject *key, size_t *at)
{
    size_t h = (size_t)(((uintptr_t)key >> 4) * (uintptr_t)0x9E3779B97F4A7C15ULL);
    for (size_t i = h & mask;; i = (i + 1) & mask) {
        if (table[i].key == key) {
            return table[i].index;
        }
        if (table[i].key == NULL) {
            *at = i;
            return -1;
        }
    }
}

static PyObject *
pack_batch(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (expect_args("pack_batch", nargs, 4) < 0) {
        return NULL;
    }
    PyObject *items = args[0];
    if (!PyList_Check(items)) {
        PyErr_SetString(PyExc_TypeError, "pack_batch: items must be a list");
        return NULL;
    }
    int encode = args[1] != Py_None;
    uint64_t writer = 0, seq = 0;
    if (encode) {
        writer = PyLong_AsUnsignedLongLong(args[1]);
        if (writer == (uint64_t)-1 && PyErr_Occurred()) {
            return NULL;
        }
        seq = PyLong_AsUnsignedLongLong(args[2]);
        if (seq == (uint64_t)-1 && PyErr_Occurred()) {
            return NULL;
        }
    }
    int64_t limit = PyLong_AsLongLong(args[3]);
    if (limit == -1 && PyErr_Occurred()) {
        return NULL;
    }
    int64_t mark = monotonic_ns();
    Py_ssize_t n = PyList_GET_SIZE(items);
    size_t cap = 8;
    while (cap < 2 * (size_t)n) {
        cap <<= 1;
    }
    PyObject *order = NULL, *newest = NULL, *message = NULL, *owners = NULL, *result = NULL;
    Entry *table = PyMem_Calloc(cap, sizeof(Entry));
    uint16_t *index = PyMem_Malloc(sizeof(uint16_t) * (size_t)(n ? n : 1));
    PyObject **last = PyMem_Malloc(sizeof(PyObject *) * (size_t)(n ? n : 1)); /* borrowed, per tag */
    Tag *tags = PyMem_Calloc((size_t)(n ? n : 1), sizeof(Tag));
    Text *texts = NULL;
    Py_ssize_t n_tags = 0, n_texts = 0;
    if (table == NULL || index == NULL || last == NULL || tags == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    if ((order = PyList_New(0)) == NULL) {
        goto done;
    }
    /* Each sample's tag position; the tags in the order first seen. */
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PyList_GET_ITEM(items, i);
        if (!PyTuple_Check(item) || PyTuple_GET_SIZE(item) != 3) {
            PyErr_Format(PyExc_TypeError, "pack_batch: sample %zd is not a (channel, value, time) tuple", i);
            goto done;
        }
        PyObject *ch = PyTuple_GET_ITEM(item, 0);
        size_t at = 0;
        Py_ssize_t k = lookup(table, cap - 1, ch, &at);
        if (k < 0) {
            if (n_tags >= UINT16_MAX) { /* the header counts tags in a u16 */
                PyErr_SetString(PyExc_OverflowError, "pack_batch: more than 65535 tags in one batch");
                goto done;
            }
            k = n_tags++;
            table[at].key = ch;
            table[at].index = k;
            if (PyList_Append(order, ch) < 0) {
                goto done;
            }
        }
        index[i] = (uint16_t)k;
        last[k] = PyTuple_GET_ITEM(item, 1);
    }
    if ((newest = PyList_New(n_tags)) == NULL) {
        goto done;
    }
    for (Py_ssize_t k = 0; k < n_tags; k++) {
        PyList_SET_ITEM(newest, k, Py_NewRef(last[k]));
    }
    if (!encode) {
        result = PyTuple_Pack(3, order, newest, Py_None);
        goto done;
    }
    /* The tag table. */
    Py_ssize_t size = 32; /* header: "<4sBBHIQQI" */
    for (Py_ssize_t k = 0; k < n_tags; k++) {
        PyObject *ch = PyList_GET_ITEM(order, k);
        PyObject *code = PyObject_GetAttr(ch, s_code);
        if (code == NULL) {
            goto done;
        }
        long c = PyLong_AsLong(code);
        Py_DECREF(code);
        if (c == -1 && PyErr_Occurred()) {
            goto done;
        }
        if (c < 0 || c >= N_CODES) {
            PyErr_Format(PyExc_ValueError, "pack_batch: a channel's type code is %ld, not 0-%d", c, N_CODES - 1);
            goto done;
        }
        tags[k].code = (int)c;
        PyObject *tag = PyObject_GetAttr(ch, s_tag_bytes);
        if (tag == NULL) {
            goto done;
        }
        tags[k].tag = tag;
        if (!PyBytes_Check(tag) || PyBytes_GET_SIZE(tag) > UINT16_MAX) {
            PyErr_SetString(PyExc_ValueError, "pack_batch: a channel's tag_bytes is not bytes of at most 65535");
            goto done;
        }
        size += 3 + PyBytes_GET_SIZE(tag);
    }
    /* The texts of String samples, numbered in order. */
    Py_ssize_t text_bytes = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (tags[index[i]].code != CODE_STRING) {
            continue;
        }
        if (texts == NULL && (texts = PyMem_Malloc(sizeof(Text) * (size_t)n)) == NULL) {
            PyErr_NoMemory();
            goto done;
        }
        PyObject *value = PyTuple_GET_ITEM(PyList_GET_ITEM(items, i), 1);
        Text *t = &texts[n_texts];
#if PY_VERSION_HEX < 0x030C0000
        if (PyUnicode_CheckExact(value) && PyUnicode_READY(value) < 0) {
            goto done;
        }
#endif
        if (PyUnicode_CheckExact(value) && PyUnicode_IS_ASCII(value)) {
            t->data = (const char *)PyUnicode_DATA(value);
            t->size = PyUnicode_GET_LENGTH(value);
        }
        else {
            PyObject *text = PyUnicode_CheckExact(value) ? Py_NewRef(value) : PyObject_Str(value);
            PyObject *utf8 = text == NULL ? NULL : PyUnicode_AsEncodedString(text, "utf-8", "replace");
            Py_XDECREF(text);
            if (utf8 == NULL) {
                goto done;
            }
            if (owners == NULL && (owners = PyList_New(0)) == NULL) {
                Py_DECREF(utf8);
                goto done;
            }
            int rc = PyList_Append(owners, utf8);
            Py_DECREF(utf8);
            if (rc < 0) {
                goto done;
            }
            t->data = PyBytes_AS_STRING(utf8);
            t->size = PyBytes_GET_SIZE(utf8);
        }
        if (t->size > (Py_ssize_t)UINT32_MAX) {
            PyErr_SetString(PyExc_OverflowError, "pack_batch: a text is longer than 4 GiB");
            goto done;
        }
        text_bytes += t->size;
        n_texts++;
        if (i % BREATHE_EVERY == BREATHE_EVERY - 1) {
            breathe(&mark, limit);
        }
    }
    Py_ssize_t tags_end = size + pad8(size);
    Py_ssize_t times_at = tags_end + 2 * n + pad8(2 * n);
    Py_ssize_t values_at = times_at + 8 * n;
    Py_ssize_t strings_at = values_at + 8 * n;
    Py_ssize_t payload = strings_at + 4 * n_texts + text_bytes;
    if (payload > (Py_ssize_t)UINT32_MAX) {
        PyErr_SetString(PyExc_OverflowError, "pack_batch: a batch of more than 4 GiB");
        goto done;
    }
    if ((message = PyBytes_FromStringAndSize(NULL, 16 + payload)) == NULL) {
        goto done;
    }
    char *out = PyBytes_AS_STRING(message);
    memset(out, 0, (size_t)(16 + payload));
    /* CDR: the encapsulation header, layout.dim (empty), layout.data_offset, data's length. */
    memcpy(out, "\x00\x01\x00\x00", 4);
    put32(out + 12, (uint32_t)payload);
    char *p = out + 16;
    memcpy(p, "DBGL", 4);
    p[4] = 2; /* version */
    p[5] = 0; /* flags */
    put16(p + 6, (uint16_t)n_tags);
    put32(p + 8, (uint32_t)n);
    put64(p + 12, writer);
    put64(p + 20, seq);
    put32(p + 28, (uint32_t)n_texts);
    char *q = p + 32;
    for (Py_ssize_t k = 0; k < n_tags; k++) {
        Py_ssize_t len = PyBytes_GET_SIZE(tags[k].tag);
        q[0] = (char)tags[k].code;
        put16(q + 1, (uint16_t)len);
        memcpy(q + 3, PyBytes_AS_STRING(tags[k].tag), (size_t)len);
        q += 3 + len;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        put16(p + tags_end + 2 * i, index[i]);
    }
    Py_ssize_t text_no = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PyList_GET_ITEM(items, i);
        long long t = PyLong_AsLongLong(PyTuple_GET_ITEM(item, 2));
        if (t == -1 && PyErr_Occurred()) {
            goto done;
        }
        put64(p + times_at + 8 * i, (uint64_t)t);
        int code = tags[index[i]].code;
        uint64_t bits;
        if (code == CODE_STRING) {
            bits = (uint64_t)text_no++;
        }
        else if (slot_bits(PyTuple_GET_ITEM(item, 1), code, &bits) < 0) {
            goto done;
        }
        put64(p + values_at + 8 * i, bits);
        if (i % BREATHE_EVERY == BREATHE_EVERY - 1) {
            breathe(&mark, limit);
        }
    }
    q = p + strings_at;
    for (Py_ssize_t j = 0; j < n_texts; j++) {
        put32(q + 4 * j, (uint32_t)texts[j].size);
    }
    q += 4 * n_texts;
    for (Py_ssize_t j = 0; j < n_texts; j++) {
        memcpy(q, texts[j].data, (size_t)texts[j].size);
        q += texts[j].size;
    }
    result = PyTuple_Pack(3, order, newest, message);
done:
    Py_XDECREF(order);
    Py_XDECREF(newest);
    Py_XDECREF(message);
    Py_XDECREF(owners);
    if (tags != NULL) {
        for (Py_ssize_t k = 0; k < n_tags; k++) {
            Py_XDECREF(tags[k].tag);
        }
    }
    PyMem_Free(table);
    PyMem_Free(index);
    PyMem_Free(last);
    PyMem_Free(tags);
    PyMem_Free(texts);
    return result;
}

PyMethodDef flush_methods[] = {
    {"take", (PyCFunction)(void (*)(void))take, METH_FASTCALL,
     "take(queue, limit) -> list: pop up to `limit` samples from the queue's left end (fewer if it empties)."},
    {"pack_batch", (PyCFunction)(void (*)(void))pack_batch, METH_FASTCALL,
     "pack_batch(items, writer, seq, breathe_ns) -> (order, newest, message): the samples' channels (first "
     "seen first), each one's last value, and the batch message's CDR bytes (None when writer is None)."},
    {NULL, NULL, 0, NULL},
};
