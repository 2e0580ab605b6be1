/* touch_graph._cdr_accel: the compiled twin of touch_graph/cdr.py.
 *
 * One interpreter serves every message type. touch_graph/cdr_accel.py walks rosbags' field
 * definitions once per type (as cdr.py's generators do) and hands the result here as a layout
 * program: a list of layouts, one per message type reached (layout 0 is the type itself), each
 * its class and its fields in order. Encoding and decoding walk that program; nothing is
 * generated per type.
 *
 * The bytes are those of cdr.py (and rosbags, and ROS 2): XCDR1 little endian, the 4-byte
 * encapsulation header, every primitive aligned to its size relative to the end of the header,
 * the elements of an empty primitive sequence not aligned. Decoded arrays are read-only views
 * of the received bytes; decoded messages are made without __init__, their slots set directly.
 *
 * Errors: every length read is checked against the buffer before it is used. A failure (ours or
 * one raised by an API we call on the caller's values) is explained by the Python codec: the
 * codec calls its `explain_encode` / `explain_decode` (cdr.py's encode / decode), which raises
 * the MessageError with the Python codec's exact text. Failures are rare, so this costs nothing
 * on the hot path and gives one wording for both codecs. Without explainers (the tests use that
 * to check this module on its own) our own reason is raised as the error class.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <stdint.h>
#include <string.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#if NPY_ABI_VERSION < 0x02000000 /* numpy 1.x headers (a colcon build against the system's numpy) */
#define PyDataType_ELSIZE(descr) ((descr)->elsize)
#endif

#if PY_BIG_ENDIAN
#error "the CDR accelerator copies little-endian values as they are in memory: little-endian hosts only"
#endif

#if PY_VERSION_HEX < 0x030B0000 /* public from Python 3.11 */
#define PyFloat_Pack4 _PyFloat_Pack4
#define PyFloat_Pack8 _PyFloat_Pack8
#define PyFloat_Unpack4 _PyFloat_Unpack4
#define PyFloat_Unpack8 _PyFloat_Unpack8
#endif

#define HEADER_SIZE 4
/* Least bytes one element of a sequence of strings takes (a count and the zero byte), as cdr.py checks. */
#define MIN_STRING_BYTES 5

/* ------------------------------------------------------------------------------------ the program */

typedef enum { SHAPE_ONE, SHAPE_ARRAY, SHAPE_SEQUENCE } Shape;

typedef enum {
    E_BOOL, E_UINT8, E_INT8, E_INT16, E_UINT16, E_INT32, E_UINT32, E_INT64, E_UINT64, E_FLOAT32, E_FLOAT64,
    E_STRING, E_MESSAGE
} Element;

static const char *ELEMENT_NAMES[] = {"bool", "uint8", "int8", "int16", "uint16", "int32", "uint32", "int64",
                                      "uint64", "float32", "float64", "string", "message", NULL};
static const char *SHAPE_NAMES[] = {"one", "array", "sequence", NULL};
static const Py_ssize_t ELEMENT_SIZE[] = {1, 1, 1, 2, 2, 4, 4, 8, 8, 4, 8};

typedef struct {
    PyObject *name;          /* interned field name */
    Py_ssize_t slot;         /* offset of the field's slot in the layout's class; -1: go through attributes */
    Shape shape;
    Element element;
    PyArray_Descr *dtype;    /* arrays and sequences of primitives: the dtype decoded and accepted */
    Py_ssize_t length;       /* SHAPE_ARRAY: the fixed number of elements */
    Py_ssize_t seq_bound;    /* SHAPE_SEQUENCE: most elements, 0 for unbounded */
    Py_ssize_t str_bound;    /* E_STRING: most characters, 0 for unbounded */
    Py_ssize_t sub;          /* E_MESSAGE: index of the element's layout */
} Field;

typedef struct {
    PyTypeObject *cls;
    Field *fields;
    Py_ssize_t count;
} Layout;

typedef struct {
    PyObject_HEAD
    Layout *layouts;
    Py_ssize_t nlayouts;
    PyObject *typename;      /* str, for the error texts */
    PyObject *other;         /* decodes what is not little-endian CDR (rosbags) */
    PyObject *error;         /* the exception class raised (MessageError) */
    PyObject *explain_encode, *explain_decode;  /* the Python codec, or None */
    Py_ssize_t size_hint;    /* the last encoded size: the first buffer of the next encoding */
} Codec;

static int is_primitive(Element e) { return e < E_STRING; }

/* ------------------------------------------------------------------------- reading the program */

/* Index of `name` (a str) in a NULL-terminated table, or -1 with ValueError. */
static int lookup_name(PyObject *name, const char **table, const char *what)
{
    const char *text = PyUnicode_Check(name) ? PyUnicode_AsUTF8(name) : NULL;
    if (text != NULL) {
        for (int i = 0; table[i] != NULL; i++)
            if (strcmp(text, table[i]) == 0)
                return i;
    }
    if (!PyErr_Occurred())
        PyErr_Format(PyExc_ValueError, "layout program: unknown %s %R", what, name);
    return -1;
}

/* Offset of the slot `name` in `cls` when it is a plain object slot the generic attribute
 * functions would reach (so reading and writing it directly is what getattr/setattr do); else -1. */
static Py_ssize_t slot_offset(PyTypeObject *cls, PyObject *name)
{
    if (cls->tp_getattro != PyObject_GenericGetAttr || cls->tp_setattro != PyObject_GenericSetAttr)
        return -1;
    PyObject *descr = _PyType_Lookup(cls, name);  /* borrowed */
    if (descr == NULL || !Py_IS_TYPE(descr, &PyMemberDescr_Type))
        return -1;
    PyMemberDef *member = ((PyMemberDescrObject *)descr)->d_member;
    if (member->type != T_OBJECT_EX || (member->flags & READONLY))
        return -1;
    return member->offset;
}

/* One field tuple: (name, shape, element, dtype or None, length, seq_bound, str_bound, sub). */
static int read_field(Field *f, PyTypeObject *cls, PyObject *spec, Py_ssize_t nlayouts)
{
    PyObject *name, *shape, *element, *dtype;
    if (!PyArg_ParseTuple(spec, "UUUOnnnn;layout program: a field is (name, shape, element, dtype, length, "
                          "seq_bound, str_bound, sub)", &name, &shape, &element, &dtype, &f->length,
                          &f->seq_bound, &f->str_bound, &f->sub))
        return -1;
    int s = lookup_name(shape, SHAPE_NAMES, "shape"), e = lookup_name(element, ELEMENT_NAMES, "element");
    if (s < 0 || e < 0)
        return -1;
    f->shape = (Shape)s;
    f->element = (Element)e;
    Py_INCREF(name);
    PyUnicode_InternInPlace(&name);
    f->name = name;
    f->slot = slot_offset(cls, name);
    if (is_primitive(f->element) && f->shape != SHAPE_ONE) {
        if (!PyArray_DescrCheck(dtype) || PyDataType_ELSIZE((PyArray_Descr *)dtype) != ELEMENT_SIZE[f->element]) {
            PyErr_Format(PyExc_ValueError, "layout program: field %U needs a dtype of %zd bytes", name,
                         ELEMENT_SIZE[f->element]);
            return -1;
        }
        Py_INCREF(dtype);
        f->dtype = (PyArray_Descr *)dtype;
    }
    if (f->element == E_MESSAGE && (f->sub < 0 || f->sub >= nlayouts)) {
        PyErr_Format(PyExc_ValueError, "layout program: field %U names layout %zd of %zd", name, f->sub, nlayouts);
        return -1;
    }
    if (f->length < 0 || f->seq_bound < 0 || f->str_bound < 0) {
        PyErr_Format(PyExc_ValueError, "layout program: field %U has a negative size", name);
        return -1;
    }
    return 0;
}

/* The program: a list of (class, (field, ...)). Fills self->layouts. */
static int read_program(Codec *self, PyObject *program)
{
    if (!PyList_Check(program) || PyList_GET_SIZE(program) == 0) {
        PyErr_SetString(PyExc_TypeError, "layout program: a non-empty list of (class, fields)");
        return -1;
    }
    Py_ssize_t n = PyList_GET_SIZE(program);
    self->layouts = PyMem_Calloc((size_t)n, sizeof(Layout));
    if (self->layouts == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    self->nlayouts = n;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *cls, *fields;
        if (!PyArg_ParseTuple(PyList_GET_ITEM(program, i), "O!O!;layout program: a layout is (class, fields)",
                              &PyType_Type, &cls, &PyTuple_Type, &fields))
            return -1;
        Layout *layout = &self->layouts[i];
        Py_INCREF(cls);
        layout->cls = (PyTypeObject *)cls;
        layout->fields = PyMem_Calloc((size_t)PyTuple_GET_SIZE(fields) + 1, sizeof(Field));
        if (layout->fields == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        for (Py_ssize_t k = 0; k < PyTuple_GET_SIZE(fields); k++) {
            layout->count = k + 1;  /* what the destructor must release */
            if (read_field(&layout->fields[k], layout->cls, PyTuple_GET_ITEM(fields, k), n) < 0)
                return -1;
        }
    }
    return 0;
}

/* -------------------------------------------------------------------------------------- encoding */

/* The output: a bytes object grown as needed and cut to its length at the end. */
typedef struct {
    PyObject *bytes;
    char *data;
    Py_ssize_t len, cap;
} Writer;

/* Room for `n` more bytes; returns where they go. */
static char *writer_take(Writer *w, Py_ssize_t n)
{
    if (n > PY_SSIZE_T_MAX / 2 - w->len) {
        PyErr_NoMemory();
        return NULL;
    }
    if (w->len + n > w->cap) {
        Py_ssize_t cap = w->cap;
        while (cap < w->len + n)
            cap *= 2;
        if (_PyBytes_Resize(&w->bytes, cap) < 0)
            return NULL;
        w->data = PyBytes_AS_STRING(w->bytes);
        w->cap = cap;
    }
    char *at = w->data + w->len;
    w->len += n;
    return at;
}

/* Zero bytes up to a multiple of `align` (1, 2, 4 or 8) of the payload position. */
static int writer_align(Writer *w, Py_ssize_t align)
{
    Py_ssize_t pad = (align - (w->len - HEADER_SIZE) % align) % align;
    if (pad == 0)
        return 0;
    char *at = writer_take(w, pad);
    if (at == NULL)
        return -1;
    memset(at, 0, (size_t)pad);
    return 0;
}

/* The value of a field of `obj` (new reference): its slot when `obj` is exactly the layout's class
 * (what getattr reads, without the lookup), else the attribute (any object with the fields does). */
static PyObject *get_field(PyObject *obj, const Layout *layout, const Field *f)
{
    if (f->slot >= 0 && Py_IS_TYPE(obj, layout->cls)) {
        PyObject *value = *(PyObject **)((char *)obj + f->slot);
        if (value != NULL)
            return Py_NewRef(value);
    }
    return PyObject_GetAttr(obj, f->name);
}

/* An integer as struct's integer formats take it: an int, or anything with __index__ (new reference). */
static PyObject *as_index(PyObject *value)
{
    if (PyLong_Check(value))
        return Py_NewRef(value);
    if (PyIndex_Check(value))
        return PyNumber_Index(value);
    PyErr_Format(PyExc_TypeError, "required argument is not an integer (got %.100s)", Py_TYPE(value)->tp_name);
    return NULL;
}

/* An integer in [lo, hi] of a signed element, into `out`. */
static int signed_value(PyObject *value, long long lo, long long hi, long long *out)
{
    PyObject *index = as_index(value);
    if (index == NULL)
        return -1;
    int overflow;
    long long x = PyLong_AsLongLongAndOverflow(index, &overflow);
    Py_DECREF(index);
    if (x == -1 && PyErr_Occurred())
        return -1;
    if (overflow || x < lo || x > hi) {
        PyErr_Format(PyExc_OverflowError, "integer out of range [%lld, %lld]", lo, hi);
        return -1;
    }
    *out = x;
    return 0;
}

/* An integer in [0, hi] of an unsigned element, into `out`. */
static int unsigned_value(PyObject *value, unsigned long long hi, unsigned long long *out)
{
    PyObject *index = as_index(value);
    if (index == NULL)
        return -1;
    unsigned long long x = PyLong_AsUnsignedLongLong(index);  /* OverflowError below 0 or above 2**64 - 1 */
    Py_DECREF(index);
    if (x == (unsigned long long)-1 && PyErr_Occurred())
        return -1;
    if (x > hi) {
        PyErr_Format(PyExc_OverflowError, "integer out of range [0, %llu]", hi);
        return -1;
    }
    *out = x;
    return 0;
}

/* One primitive, aligned, with the checks and conversions of struct's little-endian formats. */
static int encode_primitive(Writer *w, Element e, PyObject *value)
{
    Py_ssize_t size = ELEMENT_SIZE[e];
    long long s = 0;
    unsigned long long u = 0;
    double d = 0.0;
    int ok;
    switch (e) {
    case E_BOOL: ok = PyObject_IsTrue(value); u = (unsigned long long)ok; break;  /* '?' takes any truth value */
    case E_UINT8: ok = unsigned_value(value, UINT8_MAX, &u); break;
    case E_UINT16: ok = unsigned_value(value, UINT16_MAX, &u); break;
    case E_UINT32: ok = unsigned_value(value, UINT32_MAX, &u); break;
    case E_UINT64: ok = unsigned_value(value, UINT64_MAX, &u); break;
    case E_INT8: ok = signed_value(value, INT8_MIN, INT8_MAX, &s); break;
    case E_INT16: ok = signed_value(value, INT16_MIN, INT16_MAX, &s); break;
    case E_INT32: ok = signed_value(value, INT32_MIN, INT32_MAX, &s); break;
    case E_INT64: ok = signed_value(value, INT64_MIN, INT64_MAX, &s); break;
    default:  /* floats: anything with __float__ or __index__, as PyFloat_AsDouble takes it */
        d = PyFloat_AsDouble(value);
        ok = (d == -1.0 && PyErr_Occurred()) ? -1 : 0;
    }
    if (ok < 0 || writer_align(w, size) < 0)
        return -1;
    char *at = writer_take(w, size);
    if (at == NULL)
        return -1;
    switch (e) {
    case E_FLOAT32: return PyFloat_Pack4(d, at, 1);  /* OverflowError for a finite value beyond float32 */
    case E_FLOAT64: return PyFloat_Pack8(d, at, 1);
    case E_INT8: case E_INT16: case E_INT32: case E_INT64: {
        int8_t i8 = (int8_t)s; int16_t i16 = (int16_t)s; int32_t i32 = (int32_t)s; int64_t i64 = (int64_t)s;
        memcpy(at, size == 1 ? (void *)&i8 : size == 2 ? (void *)&i16 : size == 4 ? (void *)&i32 : (void *)&i64,
               (size_t)size);
        return 0;
    }
    default: {
        uint8_t u8 = (uint8_t)u; uint16_t u16 = (uint16_t)u; uint32_t u32 = (uint32_t)u; uint64_t u64 = u;
        memcpy(at, size == 1 ? (void *)&u8 : size == 2 ? (void *)&u16 : size == 4 ? (void *)&u32 : (void *)&u64,
               (size_t)size);
        return 0;
    }
    }
}

/* A uint32 count (a string's length with its zero byte, or a sequence's length). */
static int encode_count(Writer *w, Py_ssize_t count)
{
    if (count < 0 || (unsigned long long)count > UINT32_MAX) {
        PyErr_Format(PyExc_OverflowError, "%zd elements do not fit a CDR count", count);
        return -1;
    }
    if (writer_align(w, 4) < 0)
        return -1;
    char *at = writer_take(w, 4);
    if (at == NULL)
        return -1;
    uint32_t n = (uint32_t)count;
    memcpy(at, &n, 4);
    return 0;
}

/* A string: its UTF-8 bytes with a count before and a zero byte after. cdr.py calls
 * value.encode(): a str is encoded strictly (a lone surrogate fails); another object's encode()
 * must give bytes. */
static int encode_string(Writer *w, PyObject *value)
{
    PyObject *owner = NULL;
    const char *text;
    Py_ssize_t len;
    if (PyUnicode_Check(value)) {
        text = PyUnicode_AsUTF8AndSize(value, &len);  /* no copy for ASCII */
    } else {
        owner = PyObject_CallMethod(value, "encode", NULL);
        if (owner != NULL && !PyBytes_Check(owner)) {
            PyErr_Format(PyExc_TypeError, "encode() gave %.100s, not bytes", Py_TYPE(owner)->tp_name);
            Py_CLEAR(owner);
        }
        text = owner ? PyBytes_AS_STRING(owner) : NULL;
        len = owner ? PyBytes_GET_SIZE(owner) : 0;
    }
    int ok = -1;
    char *at;
    if (text != NULL && encode_count(w, len + 1) == 0 && (at = writer_take(w, len + 1)) != NULL) {
        memcpy(at, text, (size_t)len);
        at[len] = '\0';
        ok = 0;
    }
    Py_XDECREF(owner);
    return ok;
}

/* An array or a sequence of primitives: a 1-D numpy array of exactly the field's dtype (as cdr.py's
 * _coerce accepts it), copied element by element when it is not contiguous. */
static int encode_primitive_array(Writer *w, const Field *f, PyObject *value)
{
    if (!PyArray_Check(value) || PyArray_NDIM((PyArrayObject *)value) != 1 ||
        !PyArray_EquivTypes(PyArray_DESCR((PyArrayObject *)value), f->dtype)) {
        PyErr_Format(PyExc_ValueError, "field %U must be a 1-D numpy array of %S; got %.100s", f->name,
                     (PyObject *)f->dtype, Py_TYPE(value)->tp_name);
        return -1;
    }
    PyArrayObject *arr = (PyArrayObject *)value;
    Py_ssize_t n = PyArray_DIM(arr, 0), size = ELEMENT_SIZE[f->element];
    if (f->shape == SHAPE_ARRAY && n != f->length) {
        PyErr_Format(PyExc_ValueError, "field %U must hold %zd values; got %zd", f->name, f->length, n);
        return -1;
    }
    if (f->shape == SHAPE_SEQUENCE && encode_count(w, n) < 0)
        return -1;
    if ((f->shape == SHAPE_ARRAY || n > 0) && writer_align(w, size) < 0)  /* an empty sequence is not aligned */
        return -1;
    char *at = writer_take(w, n * size);
    if (at == NULL)
        return -1;
    const char *src = PyArray_DATA(arr);
    Py_ssize_t stride = PyArray_STRIDE(arr, 0);
    if (PyArray_IS_C_CONTIGUOUS(arr)) {
        memcpy(at, src, (size_t)(n * size));
    } else {
        for (Py_ssize_t i = 0; i < n; i++)
            memcpy(at + i * size, src + i * stride, (size_t)size);
    }
    return 0;
}

static int encode_message(Codec *self, Writer *w, Py_ssize_t index, PyObject *obj);

/* One element that is not in a numpy array: a primitive, a string or a message. */
static int encode_element(Codec *self, Writer *w, const Field *f, PyObject *value)
{
    if (f->element == E_STRING)
        return encode_string(w, value);
    if (f->element == E_MESSAGE)
        return encode_message(self, w, f->sub, value);
    return encode_primitive(w, f->element, value);
}

/* An array or a sequence of strings or messages: anything with len() whose items are the elements. */
static int encode_items(Codec *self, Writer *w, const Field *f, PyObject *value)
{
    Py_ssize_t n = PyObject_Length(value);
    if (n < 0)
        return -1;
    if (f->shape == SHAPE_ARRAY && n != f->length) {
        PyErr_Format(PyExc_ValueError, "field %U needs %zd items, got %zd", f->name, f->length, n);
        return -1;
    }
    if (f->shape == SHAPE_SEQUENCE && encode_count(w, n) < 0)
        return -1;
    PyObject *items = PySequence_Fast(value, "field items must be iterable");
    if (items == NULL)
        return -1;
    int ok = 0;
    if (PySequence_Fast_GET_SIZE(items) != n) {
        PyErr_Format(PyExc_ValueError, "field %U: len() said %zd items, iteration gave %zd", f->name, n,
                     PySequence_Fast_GET_SIZE(items));
        ok = -1;
    }
    for (Py_ssize_t i = 0; ok == 0 && i < n; i++) {
        /* A list is not copied: code an element runs (__index__, __float__) could shrink it. */
        if (i >= PySequence_Fast_GET_SIZE(items)) {
            PyErr_Format(PyExc_RuntimeError, "field %U changed size while it was encoded", f->name);
            ok = -1;
            break;
        }
        PyObject *item = Py_NewRef(PySequence_Fast_GET_ITEM(items, i));
        ok = encode_element(self, w, f, item);
        Py_DECREF(item);
    }
    Py_DECREF(items);
    return ok;
}

/* The fields of `obj` as layout `index` orders them (nested messages inline, without a header). */
static int encode_message(Codec *self, Writer *w, Py_ssize_t index, PyObject *obj)
{
    const Layout *layout = &self->layouts[index];
    for (Py_ssize_t k = 0; k < layout->count; k++) {
        const Field *f = &layout->fields[k];
        PyObject *value = get_field(obj, layout, f);
        if (value == NULL)
            return -1;
        int ok;
        if (f->shape == SHAPE_ONE)
            ok = encode_element(self, w, f, value);
        else if (is_primitive(f->element))
            ok = encode_primitive_array(w, f, value);
        else
            ok = encode_items(self, w, f, value);
        Py_DECREF(value);
        if (ok < 0)
            return -1;
    }
    return 0;
}

/* -------------------------------------------------------------------------------------- decoding */

/* The input: `pos` indexes `data`, whose first 4 bytes are the header. */
typedef struct {
    PyObject *bytes;
    const unsigned char *data;
    Py_ssize_t len, pos;
} Reader;

/* Bounds check before every read: `n` bytes must be left at `pos`. */
static int reader_has(const Reader *r, Py_ssize_t n, const Field *f)
{
    if (n <= r->len - r->pos)
        return 0;
    PyErr_Format(PyExc_ValueError, "field %U: %zd bytes needed at offset %zd, %zd left", f->name, n,
                 r->pos - HEADER_SIZE, r->len - r->pos);
    return -1;
}

/* Skip the padding up to a multiple of `align` of the payload position (checked by the next read). */
static void reader_align(Reader *r, Py_ssize_t align)
{
    r->pos += (align - (r->pos - HEADER_SIZE) % align) % align;
}

/* A uint32 count, aligned and bounds-checked. */
static int decode_count(Reader *r, const Field *f, Py_ssize_t *out)
{
    reader_align(r, 4);
    if (reader_has(r, 4, f) < 0)
        return -1;
    uint32_t n;
    memcpy(&n, r->data + r->pos, 4);
    r->pos += 4;
    *out = (Py_ssize_t)n;
    return 0;
}

/* One primitive as struct's little-endian formats unpack it (bool: any non-zero byte is True). */
static PyObject *decode_primitive(Reader *r, const Field *f, Element e)
{
    Py_ssize_t size = ELEMENT_SIZE[e];
    reader_align(r, size);
    if (reader_has(r, size, f) < 0)
        return NULL;
    const unsigned char *at = r->data + r->pos;
    r->pos += size;
    int8_t i8; int16_t i16; int32_t i32; int64_t i64; uint16_t u16; uint32_t u32; uint64_t u64;
    switch (e) {
    case E_BOOL: return PyBool_FromLong(at[0] != 0);
    case E_UINT8: return PyLong_FromLong(at[0]);
    case E_INT8: memcpy(&i8, at, 1); return PyLong_FromLong(i8);
    case E_INT16: memcpy(&i16, at, 2); return PyLong_FromLong(i16);
    case E_UINT16: memcpy(&u16, at, 2); return PyLong_FromLong(u16);
    case E_INT32: memcpy(&i32, at, 4); return PyLong_FromLong(i32);
    case E_UINT32: memcpy(&u32, at, 4); return PyLong_FromUnsignedLong(u32);
    case E_INT64: memcpy(&i64, at, 8); return PyLong_FromLongLong(i64);
    case E_UINT64: memcpy(&u64, at, 8); return PyLong_FromUnsignedLongLong(u64);
    case E_FLOAT32: return PyFloat_FromDouble(PyFloat_Unpack4((const char *)at, 1));
    default: return PyFloat_FromDouble(PyFloat_Unpack8((const char *)at, 1));
    }
}

/* A string: a count (its bytes with the zero byte), strict UTF-8, the zero byte, the bound in characters. */
static PyObject *decode_string(Reader *r, const Field *f)
{
    Py_ssize_t n;
    if (decode_count(r, f, &n) < 0)
        return NULL;
    if (n < 1 || n > r->len - r->pos || r->data[r->pos + n - 1] != 0) {
        PyErr_Format(PyExc_ValueError, "string %U: length %zd at offset %zd", f->name, n, r->pos - HEADER_SIZE);
        return NULL;
    }
    PyObject *text = PyUnicode_DecodeUTF8((const char *)r->data + r->pos, n - 1, NULL);
    if (text == NULL)
        return NULL;
    if (f->str_bound && PyUnicode_GET_LENGTH(text) > f->str_bound) {
        PyErr_Format(PyExc_ValueError, "string %U is longer than its bound %zd", f->name, f->str_bound);
        Py_DECREF(text);
        return NULL;
    }
    r->pos += n;
    return text;
}

/* The number of elements of an array (fixed) or a sequence (read, then checked against its bound). */
static int decode_length(Reader *r, const Field *f, Py_ssize_t *n)
{
    if (f->shape == SHAPE_ARRAY) {
        *n = f->length;
        return 0;
    }
    if (decode_count(r, f, n) < 0)
        return -1;
    if (f->seq_bound && *n > f->seq_bound) {
        PyErr_Format(PyExc_ValueError, "sequence %U holds %zd values, more than its bound %zd", f->name, *n,
                     f->seq_bound);
        return -1;
    }
    return 0;
}

/* An array or a sequence of primitives: a read-only 1-D view of the received bytes (base: the bytes). */
static PyObject *decode_primitive_array(Reader *r, const Field *f)
{
    Py_ssize_t n, size = ELEMENT_SIZE[f->element];
    if (decode_length(r, f, &n) < 0)
        return NULL;
    if (f->shape == SHAPE_ARRAY || n > 0)  /* an empty sequence is not aligned */
        reader_align(r, size);
    if (r->pos > r->len || n > (r->len - r->pos) / size) {  /* a huge count in garbage: checked, not allocated */
        PyErr_Format(PyExc_ValueError, "field %U: %zd values of %zd bytes at offset %zd, %zd bytes left", f->name,
                     n, size, r->pos - HEADER_SIZE, r->len - r->pos);
        return NULL;
    }
    npy_intp dims[1] = {(npy_intp)n};
    Py_INCREF(f->dtype);  /* the constructor takes this reference */
    PyObject *view = PyArray_NewFromDescr(&PyArray_Type, f->dtype, 1, dims, NULL, (void *)(r->data + r->pos),
                                          0 /* not writeable */, NULL);
    if (view == NULL)
        return NULL;
    Py_INCREF(r->bytes);  /* the array takes this reference: the bytes live as long as the view */
    if (PyArray_SetBaseObject((PyArrayObject *)view, r->bytes) < 0) {
        Py_DECREF(view);
        return NULL;
    }
    r->pos += n * size;
    return view;
}

static PyObject *decode_message(Codec *self, Reader *r, Py_ssize_t index);

static PyObject *decode_element(Codec *self, Reader *r, const Field *f)
{
    if (f->element == E_STRING)
        return decode_string(r, f);
    if (f->element == E_MESSAGE)
        return decode_message(self, r, f->sub);
    return decode_primitive(r, f, f->element);
}

/* An array or a sequence of strings or messages, as a list. */
static PyObject *decode_items(Codec *self, Reader *r, const Field *f)
{
    Py_ssize_t n;
    if (decode_length(r, f, &n) < 0)
        return NULL;
    Py_ssize_t least = f->element == E_STRING ? MIN_STRING_BYTES : 1;
    if (f->shape == SHAPE_SEQUENCE && n > (r->len - r->pos) / least) {  /* before the list is allocated */
        PyErr_Format(PyExc_ValueError, "sequence %U: %zd items cannot fit in %zd bytes", f->name, n,
                     r->len - r->pos);
        return NULL;
    }
    PyObject *list = PyList_New(n);
    if (list == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = decode_element(self, r, f);
        if (item == NULL) {
            Py_DECREF(list);  /* the unset items are NULL, which a list releases safely */
            return NULL;
        }
        PyList_SET_ITEM(list, i, item);
    }
    return list;
}

/* Store `value` (a reference this takes) in a field of a message this module made. */
static int set_field(PyObject *message, const Field *f, PyObject *value)
{
    if (f->slot >= 0) {
        PyObject **slot = (PyObject **)((char *)message + f->slot);
        Py_XSETREF(*slot, value);
        return 0;
    }
    int ok = PyObject_SetAttr(message, f->name, value);
    Py_DECREF(value);
    return ok;
}

/* A new message of layout `index`, made without __init__ (as object.__new__), its fields decoded. */
static PyObject *decode_message(Codec *self, Reader *r, Py_ssize_t index)
{
    const Layout *layout = &self->layouts[index];
    PyObject *message = layout->cls->tp_alloc(layout->cls, 0);
    if (message == NULL)
        return NULL;
    for (Py_ssize_t k = 0; k < layout->count; k++) {
        const Field *f = &layout->fields[k];
        PyObject *value;
        if (f->shape == SHAPE_ONE)
            value = decode_element(self, r, f);
        else if (is_primitive(f->element))
            value = decode_primitive_array(r, f);
        else
            value = decode_items(self, r, f);
        if (value == NULL || set_field(message, f, value) < 0) {
            Py_DECREF(message);
            return NULL;
        }
    }
    return message;
}

/* ------------------------------------------------------------------------------- the codec type */

/* Turn the failure being raised into the error class. Errors that are not about the input
 * (MemoryError, KeyboardInterrupt and other BaseExceptions) pass as they are. With an explainer,
 * the Python codec is run on the same input: its MessageError is raised. */
static PyObject *fail(Codec *self, const char *verb, PyObject *explainer, PyObject *subject, PyObject *pad)
{
    if (!PyErr_ExceptionMatches(PyExc_Exception) || PyErr_ExceptionMatches(PyExc_MemoryError))
        return NULL;
    PyObject *type, *cause, *trace;
    PyErr_Fetch(&type, &cause, &trace);
    PyErr_NormalizeException(&type, &cause, &trace);
    const char *note = "";
    if (explainer != Py_None) {
        PyObject *result = pad ? PyObject_CallFunctionObjArgs(explainer, subject, pad, NULL)
                               : PyObject_CallOneArg(explainer, subject);
        if (result == NULL) {  /* the Python codec's error, text and all */
            Py_XDECREF(type); Py_XDECREF(cause); Py_XDECREF(trace);
            return NULL;
        }
        Py_DECREF(result);
        note = " (the Python codec accepts this: please report the difference)";
    }
    PyObject *text = pad ? PyUnicode_FromFormat("cannot %s %U: %S%s", verb, self->typename, cause, note)
                         : PyUnicode_FromFormat("cannot %s %zd bytes as %U: %S%s", verb, PyBytes_GET_SIZE(subject),
                                                self->typename, cause, note);
    PyObject *error = text ? PyObject_CallOneArg(self->error, text) : NULL;
    Py_XDECREF(text);
    if (error != NULL) {
        PyException_SetCause(error, cause);  /* takes the reference */
        PyErr_SetObject((PyObject *)Py_TYPE(error), error);
        Py_DECREF(error);
    } else {
        Py_XDECREF(cause);
    }
    Py_XDECREF(type); Py_XDECREF(trace);
    return NULL;
}

static PyObject *Codec_encode(Codec *self, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames)
{
    static const char *usage = "encode(message, pad=False)";
    PyObject *message = nargs > 0 ? args[0] : NULL, *pad = nargs > 1 ? args[1] : Py_False;
    Py_ssize_t nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    for (Py_ssize_t i = 0; i < nkw; i++) {
        PyObject *key = PyTuple_GET_ITEM(kwnames, i), **target = NULL;
        if (PyUnicode_CompareWithASCIIString(key, "message") == 0 && nargs < 1)
            target = &message;
        else if (PyUnicode_CompareWithASCIIString(key, "pad") == 0 && nargs < 2)
            target = &pad;
        if (target == NULL) {
            PyErr_Format(PyExc_TypeError, "%s: unexpected keyword %R", usage, key);
            return NULL;
        }
        *target = args[nargs + i];
    }
    if (message == NULL || nargs > 2) {
        PyErr_Format(PyExc_TypeError, "%s takes a message and an optional pad", usage);
        return NULL;
    }
    Py_ssize_t cap = self->size_hint > 64 ? self->size_hint : 64;
    Writer w = {PyBytes_FromStringAndSize(NULL, cap), NULL, HEADER_SIZE, cap};
    if (w.bytes == NULL)
        return NULL;
    w.data = PyBytes_AS_STRING(w.bytes);
    memcpy(w.data, "\x00\x01\x00\x00", HEADER_SIZE);  /* XCDR1 little endian, options zero */
    int ok = encode_message(self, &w, 0, message);
    if (ok == 0) {
        int padded = PyObject_IsTrue(pad);  /* as cdr.py: `if pad and p % 4`, after the fields */
        ok = padded < 0 ? -1 : padded ? writer_align(&w, 4) : 0;
    }
    if (ok < 0 || _PyBytes_Resize(&w.bytes, w.len) < 0) {
        Py_XDECREF(w.bytes);
        return fail(self, "serialise", self->explain_encode, message, pad);
    }
    self->size_hint = w.len;
    return w.bytes;
}

static PyObject *Codec_decode(Codec *self, PyObject *data)
{
    if (!PyBytes_Check(data)) {  /* another bytes-like type: the Python codec takes it as it is */
        if (self->explain_decode != Py_None)
            return PyObject_CallOneArg(self->explain_decode, data);
        PyErr_Format(self->error, "cannot deserialise %.100s as %U: bytes expected", Py_TYPE(data)->tp_name,
                     self->typename);
        return NULL;
    }
    const unsigned char *bytes = (const unsigned char *)PyBytes_AS_STRING(data);
    Py_ssize_t len = PyBytes_GET_SIZE(data);
    if (len < 2 || bytes[0] != 0x00 || bytes[1] != 0x01)  /* not little endian CDR: big endian, or rosbags says */
        return PyObject_CallOneArg(self->other, data);
    Reader r = {data, bytes, len, HEADER_SIZE};
    PyObject *message = decode_message(self, &r, 0);
    if (message != NULL && r.pos + 3 < r.len) {  /* more than the padding up to 4 bytes left: garbage */
        Py_CLEAR(message);
        PyErr_Format(PyExc_ValueError, "%zd bytes left over after the message", r.len - r.pos);
    }
    if (message == NULL)
        return fail(self, "deserialise", self->explain_decode, data, NULL);
    return message;
}

static int Codec_init(Codec *self, PyObject *args, PyObject *kwargs)
{
    static char *keywords[] = {"typename", "program", "other", "error", "explain_encode", "explain_decode", NULL};
    PyObject *typename, *program, *other, *error, *explain_encode = Py_None, *explain_decode = Py_None;
    if (self->layouts != NULL) {
        PyErr_SetString(PyExc_TypeError, "a Codec is initialised once");
        return -1;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "UOOO|OO:Codec", keywords, &typename, &program, &other, &error,
                                     &explain_encode, &explain_decode))
        return -1;
    if (!PyCallable_Check(other) || !PyExceptionClass_Check(error)) {
        PyErr_SetString(PyExc_TypeError, "Codec: other must be callable and error an exception class");
        return -1;
    }
    Py_XSETREF(self->typename, Py_NewRef(typename));  /* XSETREF: an __init__ that failed may be called again */
    Py_XSETREF(self->other, Py_NewRef(other));
    Py_XSETREF(self->error, Py_NewRef(error));
    Py_XSETREF(self->explain_encode, Py_NewRef(explain_encode));
    Py_XSETREF(self->explain_decode, Py_NewRef(explain_decode));
    return read_program(self, program);
}

static void Codec_dealloc(Codec *self)
{
    for (Py_ssize_t i = 0; i < self->nlayouts; i++) {
        Layout *layout = &self->layouts[i];
        for (Py_ssize_t k = 0; layout->fields != NULL && k < layout->count; k++) {
            Py_XDECREF(layout->fields[k].name);
            Py_XDECREF(layout->fields[k].dtype);
        }
        PyMem_Free(layout->fields);
        Py_XDECREF(layout->cls);
    }
    PyMem_Free(self->layouts);
    Py_XDECREF(self->typename);
    Py_XDECREF(self->other);
    Py_XDECREF(self->error);
    Py_XDECREF(self->explain_encode);
    Py_XDECREF(self->explain_decode);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyMethodDef Codec_methods[] = {
    {"encode", (PyCFunction)(void (*)(void))Codec_encode, METH_FASTCALL | METH_KEYWORDS,
     "encode(message, pad=False) -> bytes: the CDR header and fields; pad adds zero bytes up to a multiple of 4."},
    {"decode", (PyCFunction)Codec_decode, METH_O,
     "decode(data) -> message: little-endian CDR bytes; other byte orders go to the `other` decoder."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject CodecType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "touch_graph._cdr_accel.Codec",
    .tp_basicsize = sizeof(Codec),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Codec(typename, program, other, error, explain_encode=None, explain_decode=None): the CDR encoder "
              "and decoder of one message type, interpreting its layout program (see touch_graph.cdr_accel).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Codec_init,
    .tp_dealloc = (destructor)Codec_dealloc,
    .tp_methods = Codec_methods,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_cdr_accel",
    "Compiled CDR encoding and decoding of ROS 2 messages from a layout program (see touch_graph.cdr_accel).",
    -1, NULL, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__cdr_accel(void)
{
    if (_import_array() < 0)
        return NULL;
    if (PyType_Ready(&CodecType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    Py_INCREF(&CodecType);
    if (PyModule_AddObject(m, "Codec", (PyObject *)&CodecType) < 0) {
        Py_DECREF(&CodecType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
