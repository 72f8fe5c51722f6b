// OBJ and PLY meshes, parsed from and formatted into memory (the caller does the file access).
//
// OBJ: `v x y z` and `f a b c ...` lines (indices 1-based or negative = relative, `a/t/n` forms), other
// lines skipped; polygons fan-triangulated. PLY: ascii and both binary byte orders, any scalar types;
// the vertex element's x, y, z and the face element's vertex_indices (or vertex_index) list are read,
// every other element and property is skipped (one without properties holds no data: skipped whatever its
// count). Text is parsed from a NUL-terminated copy, so strtod and strtol never run past the data.
// Out-of-range indices are errors naming the triangle. Reading and writing poll for interrupts
// (od_CheckInterrupt) every OD_IO_POLL + 1 lines, items, vertices or triangles: OD_ERROR_INTERRUPTED.
#include "opdeform/mesh.h"

#include "buffer.h"
#include "core.h"
#include "interrupt.h"
#include "mesh_check.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define OD_IO_POLL 4095 // lines, items, vertices or triangles between interrupt checks, less one (2^k - 1)

// OD_OK, or what od_CheckInterrupt says every OD_IO_POLL + 1 counts.
static od_Status od_PollEvery(long long count)
{
	return (count & OD_IO_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
}

// The mesh being read: vertices and triangles as growing buffers, and the current polygon.
typedef struct od_MeshReader
{
	od_Buffer vertices, triangles, polygon;
} od_MeshReader;

static void od_MeshReader_Free(od_MeshReader* r)
{
	od_Free(r->vertices.data);
	od_Free(r->triangles.data);
	od_Free(r->polygon.data);
}

static od_Status od_AddPolygonIndex(od_MeshReader* r, long long index)
{
	int i = index < INT_MIN ? INT_MIN : index > INT_MAX ? INT_MAX : (int)index;
	return od_BufferAppend(&r->polygon, &i, sizeof i);
}

// Fan-triangulates the current polygon (what counts as its number in messages: `what`) and clears it.
static od_Status od_EndPolygon(od_MeshReader* r, const char* what, long long number)
{
	const int* p = (const int*)r->polygon.data;
	int count = (int)(r->polygon.size / sizeof(int));
	r->polygon.size = 0;
	if (count < 3)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "%s %lld has %d vertices; a face needs at least 3", what, number, count);
	}
	for (int k = 1; k + 1 < count; ++k)
	{
		int tri[3] = { p[0], p[k], p[k + 1] };
		od_Status status = od_BufferAppend(&r->triangles, tri, sizeof tri);
		if (status != OD_OK)
		{
			return status;
		}
	}
	return OD_OK;
}

// Checks the indices and hands the arrays over to the mesh.
static od_Status od_FinishMesh(od_MeshReader* r, od_Mesh* mesh)
{
	size_t vertexCount = r->vertices.size / (3 * sizeof(double)), triangleCount = r->triangles.size / (3 * sizeof(int));
	if (vertexCount > INT_MAX / 3 || triangleCount > INT_MAX / 3)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "the mesh is too large (%zu vertices, %zu triangles)", vertexCount,
					   triangleCount);
	}
	const int* tri = (const int*)r->triangles.data;
	for (size_t t = 0; t < 3 * triangleCount; ++t)
	{
		if (tri[t] < 0 || (size_t)tri[t] >= vertexCount)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "triangle %zu refers to vertex %d, but the file has %zu vertices", t / 3,
						   tri[t], vertexCount);
		}
	}
	mesh->vertexCount = (int)vertexCount;
	mesh->triangleCount = (int)triangleCount;
	mesh->vertices = (double*)r->vertices.data;
	mesh->triangles = (int*)r->triangles.data;
	r->vertices.data = r->triangles.data = NULL;
	return OD_OK;
}

// A NUL-terminated copy of the data.
static char* od_TextCopy(const char* data, size_t size)
{
	char* text = od_Alloc(size + 1);
	if (text)
	{
		memcpy(text, data, size);
		text[size] = '\0';
	}
	return text;
}

static const char* od_SkipBlanks(const char* p)
{
	while (*p == ' ' || *p == '\t' || *p == '\r')
	{
		++p;
	}
	return p;
}

static const char* od_NextLine(const char* p)
{
	while (*p && *p != '\n')
	{
		++p;
	}
	return *p ? p + 1 : p;
}

static int od_IsBlank(char c)
{
	return c == ' ' || c == '\t' || c == '\r';
}

// ---------------------------------------------------------------------------------------------------------
// OBJ

static od_Status od_ObjVertex(od_MeshReader* r, const char* p, long long line)
{
	double v[3];
	for (int k = 0; k < 3; ++k)
	{
		char* end;
		v[k] = strtod(p, &end);
		if (end == p || !(od_IsBlank(*end) || *end == '\n' || *end == '\0'))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "line %lld: a vertex needs three numbers", line);
		}
		p = end;
	}
	return od_BufferAppend(&r->vertices, v, sizeof v);
}

static od_Status od_ObjFace(od_MeshReader* r, const char* p, long long line)
{
	long long vertexCount = (long long)(r->vertices.size / (3 * sizeof(double)));
	for (p = od_SkipBlanks(p); *p && *p != '\n'; p = od_SkipBlanks(p))
	{
		char* end;
		errno = 0;
		long long index = strtoll(p, &end, 10);
		if (end == p || errno || index == 0)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "line %lld: a face index must be a non-zero integer", line);
		}
		od_Status status = od_AddPolygonIndex(r, index > 0 ? index - 1 : vertexCount + index);
		if (status != OD_OK)
		{
			return status;
		}
		for (p = end; *p && *p != '\n' && !od_IsBlank(*p); ++p) // texture and normal indices
		{
		}
	}
	return od_EndPolygon(r, "the face on line", line);
}

// OBJ is text: a NUL byte means UTF-16 (every ASCII character has one) or binary data, which would otherwise
// load as a silently partial mesh; a UTF-8 byte order mark is skipped.
static od_Status od_CheckObjText(const char** data, size_t* size)
{
	const char* nul = memchr(*data, '\0', *size);
	if (nul)
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "byte %zu is NUL: an OBJ file is ASCII or UTF-8 text, this looks like UTF-16 text or binary "
					   "data",
					   (size_t)(nul - *data));
	}
	if (*size >= 3 && memcmp(*data, "\xEF\xBB\xBF", 3) == 0)
	{
		*data += 3;
		*size -= 3;
	}
	return OD_OK;
}

// Old Mac OS line ends: a CR not followed by LF ends a line too.
static void od_EndLinesAtCr(char* text)
{
	for (char* p = strchr(text, '\r'); p; p = strchr(p + 1, '\r'))
	{
		*p = p[1] == '\n' ? '\r' : '\n';
	}
}

od_Status od_Mesh_ParseObj(const char* data, size_t size, od_Mesh* mesh)
{
	memset(mesh, 0, sizeof *mesh);
	od_Status status = od_CheckObjText(&data, &size);
	if (status != OD_OK)
	{
		return status;
	}
	char* text = od_TextCopy(data, size);
	if (!text)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory reading an OBJ of %zu bytes", size);
	}
	od_EndLinesAtCr(text);
	od_MeshReader r;
	memset(&r, 0, sizeof r);
	long long line = 1;
	for (const char* p = text; *p && status == OD_OK; p = od_NextLine(p), ++line)
	{
		p = od_SkipBlanks(p);
		status = od_PollEvery(line);
		if (status != OD_OK)
		{
			break;
		}
		if (p[0] == 'v' && od_IsBlank(p[1]))
		{
			status = od_ObjVertex(&r, p + 2, line);
		}
		else if (p[0] == 'f' && od_IsBlank(p[1]))
		{
			status = od_ObjFace(&r, p + 2, line);
		}
	}
	status = status == OD_OK ? od_FinishMesh(&r, mesh) : status;
	od_MeshReader_Free(&r);
	od_Free(text);
	return status;
}

// ---------------------------------------------------------------------------------------------------------
// PLY

typedef enum od_PlyFormat
{
	OD_PLY_ASCII,
	OD_PLY_LITTLE,
	OD_PLY_BIG,
} od_PlyFormat;

typedef enum od_PlyType
{
	OD_PLY_NONE,
	OD_PLY_INT8,
	OD_PLY_UINT8,
	OD_PLY_INT16,
	OD_PLY_UINT16,
	OD_PLY_INT32,
	OD_PLY_UINT32,
	OD_PLY_FLOAT32,
	OD_PLY_FLOAT64,
} od_PlyType;

#define OD_PLY_MAX_ELEMENTS 16
#define OD_PLY_MAX_PROPERTIES 64

typedef struct od_PlyProperty
{
	od_PlyType type;      // scalar type, or list item type
	od_PlyType countType; // OD_PLY_NONE for a scalar
	int role;             // vertex: 0, 1, 2 for x, y, z; face: 0 for the index list; -1 otherwise
} od_PlyProperty;

typedef struct od_PlyElement
{
	int kind; // 0 vertex, 1 face, -1 other
	long long count;
	int propertyCount;
	od_PlyProperty properties[OD_PLY_MAX_PROPERTIES];
} od_PlyElement;

typedef struct od_PlyInput
{
	od_PlyFormat format;
	const char* p;   // reading position
	const char* end; // end of the data (the NUL of the text copy)
} od_PlyInput;

static od_PlyType od_PlyTypeOf(const char* name)
{
	static const struct
	{
		const char* name;
		od_PlyType type;
	} names[] = { { "char", OD_PLY_INT8 },       { "int8", OD_PLY_INT8 },     { "uchar", OD_PLY_UINT8 },
				  { "uint8", OD_PLY_UINT8 },     { "short", OD_PLY_INT16 },   { "int16", OD_PLY_INT16 },
				  { "ushort", OD_PLY_UINT16 },   { "uint16", OD_PLY_UINT16 }, { "int", OD_PLY_INT32 },
				  { "int32", OD_PLY_INT32 },     { "uint", OD_PLY_UINT32 },   { "uint32", OD_PLY_UINT32 },
				  { "float", OD_PLY_FLOAT32 },   { "float32", OD_PLY_FLOAT32 }, { "double", OD_PLY_FLOAT64 },
				  { "float64", OD_PLY_FLOAT64 } };
	for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i)
	{
		if (strcmp(name, names[i].name) == 0)
		{
			return names[i].type;
		}
	}
	return OD_PLY_NONE;
}

static int od_PlySize(od_PlyType type)
{
	static const int sizes[] = { 0, 1, 1, 2, 2, 4, 4, 4, 8 };
	return sizes[type];
}

// Reads one value of a type (binary: with the file's byte order).
static od_Status od_PlyValue(od_PlyInput* in, od_PlyType type, double* value)
{
	if (in->format == OD_PLY_ASCII)
	{
		char* end;
		*value = strtod(in->p, &end);
		if (end == in->p)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: the data ends early or holds something that is not a number");
		}
		in->p = end;
		return OD_OK;
	}
	int size = od_PlySize(type);
	if (in->end - in->p < size)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "PLY: the data ends before the elements the header declares");
	}
	unsigned char b[8];
	for (int k = 0; k < size; ++k)
	{
		b[k] = (unsigned char)in->p[in->format == OD_PLY_LITTLE ? k : size - 1 - k];
	}
	in->p += size;
	uint64_t u = 0;
	for (int k = size - 1; k >= 0; --k)
	{
		u = u << 8 | b[k];
	}
	switch (type)
	{
		case OD_PLY_INT8:
			*value = (int8_t)u;
			break;
		case OD_PLY_INT16:
			*value = (int16_t)u;
			break;
		case OD_PLY_INT32:
			*value = (int32_t)u;
			break;
		case OD_PLY_FLOAT32:
		{
			uint32_t bits = (uint32_t)u;
			float f;
			memcpy(&f, &bits, sizeof f);
			*value = f;
			break;
		}
		case OD_PLY_FLOAT64:
			memcpy(value, &u, sizeof *value);
			break;
		default: // unsigned types
			*value = (double)u;
			break;
	}
	return OD_OK;
}

// Reads one property of one element: the index list of a face into the polygon, x, y, z into xyz.
static od_Status od_PlyReadProperty(od_PlyInput* in, const od_PlyProperty* prop, od_MeshReader* r, double* xyz)
{
	double value;
	if (prop->countType == OD_PLY_NONE)
	{
		od_Status status = od_PlyValue(in, prop->type, &value);
		if (status == OD_OK && prop->role >= 0)
		{
			xyz[prop->role] = value;
		}
		return status;
	}
	od_Status status = od_PlyValue(in, prop->countType, &value);
	if (status == OD_OK && !(value >= 0.0 && value <= 1e6))
	{
		status = od_Fail(OD_ERROR_ARGUMENT, "PLY: a list length of %g", value);
	}
	int count = (int)value;
	for (int k = 0; k < count && status == OD_OK; ++k)
	{
		status = od_PlyValue(in, prop->type, &value);
		if (status == OD_OK && prop->role == 0)
		{
			status = od_AddPolygonIndex(r, value < -1e18 ? -1 : value > 1e18 ? -1 : (long long)value);
		}
	}
	return status;
}

static od_Status od_PlyElements(od_PlyInput* in, const od_PlyElement* elements, int elementCount, od_MeshReader* r)
{
	for (int e = 0; e < elementCount; ++e)
	{
		const od_PlyElement* el = &elements[e];
		if (el->propertyCount == 0)
		{
			continue; // no data in either format: 715 million such items are skipped at once, not counted out
		}
		for (long long i = 0; i < el->count; ++i)
		{
			od_Status polled = od_PollEvery(i);
			if (polled != OD_OK)
			{
				return polled;
			}
			double xyz[3] = { 0, 0, 0 };
			for (int k = 0; k < el->propertyCount; ++k)
			{
				od_Status status = od_PlyReadProperty(in, &el->properties[k], r, xyz);
				if (status != OD_OK)
				{
					return status;
				}
			}
			od_Status status = el->kind == 0	 ? od_BufferAppend(&r->vertices, xyz, sizeof xyz)
							   : el->kind == 1 ? od_EndPolygon(r, "PLY face", i)
											   : OD_OK;
			if (status != OD_OK)
			{
				return status;
			}
		}
	}
	return OD_OK;
}

// One header line (NUL-terminated words in `words`); fills the format and the elements.
static od_Status od_PlyHeaderLine(char** words, int count, od_PlyInput* in, od_PlyElement* elements,
								  int* elementCount)
{
	if (count == 0 || strcmp(words[0], "comment") == 0 || strcmp(words[0], "obj_info") == 0)
	{
		return OD_OK;
	}
	if (strcmp(words[0], "format") == 0 && count >= 2)
	{
		in->format = strcmp(words[1], "ascii") == 0				   ? OD_PLY_ASCII
					 : strcmp(words[1], "binary_little_endian") == 0 ? OD_PLY_LITTLE
					 : strcmp(words[1], "binary_big_endian") == 0	   ? OD_PLY_BIG
																	   : (od_PlyFormat)-1;
		return (int)in->format >= 0 ? OD_OK : od_Fail(OD_ERROR_ARGUMENT, "PLY: unknown format '%s'", words[1]);
	}
	if (strcmp(words[0], "element") == 0 && count >= 3)
	{
		if (*elementCount == OD_PLY_MAX_ELEMENTS)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: more than %d elements", OD_PLY_MAX_ELEMENTS);
		}
		od_PlyElement* el = &elements[(*elementCount)++];
		memset(el, 0, sizeof *el);
		el->kind = strcmp(words[1], "vertex") == 0 ? 0 : strcmp(words[1], "face") == 0 ? 1 : -1;
		el->count = strtoll(words[2], NULL, 10);
		return el->count >= 0 && el->count <= INT_MAX / 3
				   ? OD_OK
				   : od_Fail(OD_ERROR_ARGUMENT, "PLY: element '%s' has a bad count '%s'", words[1], words[2]);
	}
	if (strcmp(words[0], "property") == 0 && count >= 3 && *elementCount > 0)
	{
		od_PlyElement* el = &elements[*elementCount - 1];
		if (el->propertyCount == OD_PLY_MAX_PROPERTIES)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: more than %d properties in an element", OD_PLY_MAX_PROPERTIES);
		}
		od_PlyProperty* prop = &el->properties[el->propertyCount++];
		bool list = strcmp(words[1], "list") == 0;
		if (list && count < 5)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: a list property needs a count type, an item type and a name");
		}
		prop->countType = list ? od_PlyTypeOf(words[2]) : OD_PLY_NONE;
		prop->type = od_PlyTypeOf(words[list ? 3 : 1]);
		const char* name = words[list ? 4 : 2];
		if (prop->type == OD_PLY_NONE || (list && prop->countType == OD_PLY_NONE))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: unknown type in the property '%s'", name);
		}
		prop->role = -1;
		if (el->kind == 0 && !list && name[0] >= 'x' && name[0] <= 'z' && name[1] == '\0')
		{
			prop->role = name[0] - 'x';
		}
		if (el->kind == 1 && list && (strcmp(name, "vertex_indices") == 0 || strcmp(name, "vertex_index") == 0))
		{
			prop->role = 0;
		}
		return OD_OK;
	}
	return od_Fail(OD_ERROR_ARGUMENT, "PLY: unexpected header line starting with '%s'", words[0]);
}

// Parses the header of text (NUL-terminated); leaves in->p at the first byte of the data.
static od_Status od_PlyHeader(char* text, od_PlyInput* in, od_PlyElement* elements, int* elementCount)
{
	if (strncmp(text, "ply", 3) != 0 || (text[3] != '\n' && text[3] != '\r'))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "PLY: the data does not start with 'ply'");
	}
	in->format = (od_PlyFormat)-1;
	char* line = (char*)od_NextLine(text);
	for (;;)
	{
		if (!*line)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: the header has no end_header line");
		}
		char* next = (char*)od_NextLine(line);
		char* words[8];
		int count = 0;
		for (char* p = line; p < next;)
		{
			while (p < next && (od_IsBlank(*p) || *p == '\n'))
			{
				*p++ = '\0';
			}
			if (p < next && *p && count < 8)
			{
				words[count++] = p;
			}
			while (p < next && *p && !od_IsBlank(*p) && *p != '\n')
			{
				++p;
			}
		}
		if (count > 0 && strcmp(words[0], "end_header") == 0)
		{
			in->p = next;
			break;
		}
		od_Status status = od_PlyHeaderLine(words, count, in, elements, elementCount);
		if (status != OD_OK)
		{
			return status;
		}
		line = next;
	}
	bool vertices = false;
	for (int e = 0; e < *elementCount; ++e)
	{
		const od_PlyElement* el = &elements[e];
		int roles = 0;
		for (int k = 0; k < el->propertyCount; ++k)
		{
			roles |= el->properties[k].role >= 0 ? 1 << el->properties[k].role : 0;
		}
		vertices = vertices || el->kind == 0;
		if ((el->kind == 0 && roles != 7) || (el->kind == 1 && roles != 1))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "PLY: the %s element lacks %s", el->kind == 0 ? "vertex" : "face",
						   el->kind == 0 ? "x, y or z" : "a vertex_indices list");
		}
	}
	if ((int)in->format < 0 || !vertices)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "PLY: the header names no format or no vertex element");
	}
	return OD_OK;
}

od_Status od_Mesh_ParsePly(const char* data, size_t size, od_Mesh* mesh)
{
	memset(mesh, 0, sizeof *mesh);
	char* text = od_TextCopy(data, size);
	if (!text)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory reading a PLY of %zu bytes", size);
	}
	od_PlyElement* elements = od_Alloc(sizeof(od_PlyElement) * OD_PLY_MAX_ELEMENTS);
	od_MeshReader r;
	memset(&r, 0, sizeof r);
	od_PlyInput in = { OD_PLY_ASCII, text, text + size };
	int elementCount = 0;
	od_Status status = elements ? od_PlyHeader(text, &in, elements, &elementCount)
								: od_Fail(OD_ERROR_MEMORY, "out of memory reading a PLY header");
	status = status == OD_OK ? od_PlyElements(&in, elements, elementCount, &r) : status;
	status = status == OD_OK ? od_FinishMesh(&r, mesh) : status;
	od_MeshReader_Free(&r);
	od_Free(elements);
	od_Free(text);
	return status;
}

void od_Mesh_Free(od_Mesh* mesh)
{
	od_Free(mesh->vertices);
	od_Free(mesh->triangles);
	memset(mesh, 0, sizeof *mesh);
}

// ---------------------------------------------------------------------------------------------------------
// Writing

static od_Status od_Print(od_Buffer* b, const char* format, ...) OD_PRINTF(2, 3);

static od_Status od_Print(od_Buffer* b, const char* format, ...)
{
	char line[256];
	va_list args;
	va_start(args, format);
	int n = vsnprintf(line, sizeof line, format, args);
	va_end(args);
	return od_BufferAppend(b, line, (size_t)n);
}

typedef od_Status od_MeshWriter(od_Buffer* b, int vertexCount, const double* vertices, int triangleCount,
								const int* triangles);

// Checks the mesh, writes it into a new buffer and hands the buffer over.
static od_Status od_Format(od_MeshWriter* write, int vertexCount, const double* vertices, int triangleCount,
						   const int* triangles, char** data, size_t* size)
{
	*data = NULL;
	*size = 0;
	od_Buffer b = { 0 };
	od_Status status = od_CheckMesh(vertexCount, vertices, triangleCount, triangles, false);
	status = status == OD_OK ? write(&b, vertexCount, vertices, triangleCount, triangles) : status;
	if (status != OD_OK)
	{
		od_Free(b.data);
		return status;
	}
	*data = b.data;
	*size = b.size;
	return OD_OK;
}

static od_Status od_WriteObj(od_Buffer* b, int vertexCount, const double* vertices, int triangleCount,
							 const int* triangles)
{
	od_Status status = od_Print(b, "# opdeform: %d vertices, %d triangles\n", vertexCount, triangleCount);
	for (int v = 0; v < vertexCount && status == OD_OK; ++v)
	{
		const double* p = vertices + 3 * v;
		status = od_PollEvery(v);
		status = status == OD_OK ? od_Print(b, "v %.17g %.17g %.17g\n", p[0], p[1], p[2]) : status;
	}
	for (int t = 0; t < triangleCount && status == OD_OK; ++t)
	{
		const int* tri = triangles + 3 * t;
		status = od_PollEvery(t);
		status = status == OD_OK ? od_Print(b, "f %d %d %d\n", tri[0] + 1, tri[1] + 1, tri[2] + 1) : status;
	}
	return status;
}

od_Status od_Mesh_FormatObj(int vertexCount, const double* vertices, int triangleCount, const int* triangles,
							char** data, size_t* size)
{
	return od_Format(od_WriteObj, vertexCount, vertices, triangleCount, triangles, data, size);
}

static od_Status od_AppendLittle(od_Buffer* b, uint64_t bits, int size)
{
	unsigned char bytes[8];
	for (int k = 0; k < size; ++k)
	{
		bytes[k] = (unsigned char)(bits >> (8 * k));
	}
	return od_BufferAppend(b, bytes, (size_t)size);
}

static od_Status od_WritePly(od_Buffer* b, int vertexCount, const double* vertices, int triangleCount,
							 const int* triangles)
{
	od_Status status = od_Print(b,
								"ply\nformat binary_little_endian 1.0\ncomment opdeform\nelement vertex %d\n"
								"property double x\nproperty double y\nproperty double z\n",
								vertexCount);
	status = status == OD_OK ? od_Print(b, "element face %d\nproperty list uchar int vertex_indices\nend_header\n",
										triangleCount)
							 : status;
	for (int i = 0; i < 3 * vertexCount && status == OD_OK; ++i)
	{
		uint64_t bits;
		memcpy(&bits, vertices + i, sizeof bits);
		status = od_AppendLittle(b, bits, 8);
	}
	for (int t = 0; t < triangleCount && status == OD_OK; ++t)
	{
		status = od_AppendLittle(b, 3, 1);
		for (int k = 0; k < 3 && status == OD_OK; ++k)
		{
			status = od_AppendLittle(b, (uint32_t)triangles[3 * t + k], 4);
		}
	}
	return status;
}

od_Status od_Mesh_FormatPly(int vertexCount, const double* vertices, int triangleCount, const int* triangles,
							char** data, size_t* size)
{
	return od_Format(od_WritePly, vertexCount, vertices, triangleCount, triangles, data, size);
}

void od_Mesh_FreeData(char* data)
{
	od_Free(data);
}
