/* pyconfig.h for the cross-built extension (scripts/package_platform.py): CPython 3.11's headers compiled for
   Windows x64 (MinGW ABI, linked against python3.dll: the limited API) or macOS (LP64), where the build
   machine's pyconfig.h describes Linux. Only what the limited API's headers read: the sizes of the C types,
   the platform names, and on Windows that the Python API is imported from a DLL (PyMODINIT_FUNC exported). */
#ifndef OD_CROSS_PYCONFIG_H
#define OD_CROSS_PYCONFIG_H

#define SIZEOF_SHORT 2
#define SIZEOF_INT 4
#define SIZEOF_LONG_LONG 8
#define SIZEOF_FLOAT 4
#define SIZEOF_DOUBLE 8
#define SIZEOF_VOID_P 8
#define SIZEOF_SIZE_T 8
#define SIZEOF_TIME_T 8
#define SIZEOF_FPOS_T 8
#define ALIGNOF_SIZE_T 8
#define ALIGNOF_LONG 8
#define HAVE_STDARG_PROTOTYPES 1
#define HAVE_WCHAR_H 1

#if defined(_WIN32)
#define MS_WIN32
#define MS_WIN64
#define MS_WINDOWS
#define NT_THREADS
#define SIZEOF_LONG 4
#define SIZEOF_WCHAR_T 2
#define SIZEOF_OFF_T 4
#define SIZEOF_PID_T 4
#define Py_ENABLE_SHARED 1
#define HAVE_DECLSPEC_DLL
#define PY_LLONG_MIN LLONG_MIN
#define PY_LLONG_MAX LLONG_MAX
#define PY_ULLONG_MAX ULLONG_MAX
#elif defined(__APPLE__)
#define SIZEOF_LONG 8
#define SIZEOF_WCHAR_T 4
#define SIZEOF_OFF_T 8
#define SIZEOF_PID_T 4
#define HAVE_SSIZE_T 1
#define HAVE_UNISTD_H 1
#define HAVE_PTHREAD_H 1
#define WITH_DOC_STRINGS 1
#else
#error "scripts/cross/pyconfig.h is for Windows and macOS only: Linux builds use the system's Python headers"
#endif

#endif
