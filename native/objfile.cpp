// The OBJ reader's bulk path (texbake/mesh/objfile.py), in one pass over the bytes: positions,
// texture coordinates and faces, fan-triangulated, one vertex per distinct (position,
// texcoord) pair in order of first use; the g/o and usemtl lines kept with the count of triangles
// before each, from which objfile.py labels each face's part and material. It takes only files it reads exactly as the line
// reader does and gives up (None) on anything else, which objfile.py then reads: a byte
// outside ASCII or an odd space (a line break or separator to str.split()), a number field
// that is not a plain decimal, a face corner not written like the file's first, a sign before
// an index, an index of 0 or out of range, a short line. Numbers are converted by
// std::from_chars, correctly rounded, as float() rounds.
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <charconv>
#include <climits>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "arrays.hpp"

namespace texbake {
namespace {

inline bool is_space(char c) { return c == ' ' || c == '\t'; }

// a decimal number field: sign, digits with at most one point, an exponent (float()'s syntax less
// "inf", "nan" and underscores)
bool parse_number(std::string_view field, double& out) {
  size_t i = 0, n = field.size();
  if (i < n && (field[i] == '+' || field[i] == '-')) ++i;
  size_t digits = 0;
  while (i < n && field[i] >= '0' && field[i] <= '9') ++i, ++digits;
  if (i < n && field[i] == '.') {
    ++i;
    while (i < n && field[i] >= '0' && field[i] <= '9') ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < n && (field[i] == 'e' || field[i] == 'E')) {
    ++i;
    if (i < n && (field[i] == '+' || field[i] == '-')) ++i;
    size_t exponent = 0;
    while (i < n && field[i] >= '0' && field[i] <= '9') ++i, ++exponent;
    if (exponent == 0) return false;
  }
  if (i != n) return false;
  const char* begin = field.data() + (field[0] == '+' ? 1 : 0);
  const auto [end, error] = std::from_chars(begin, field.data() + n, out);
  return error == std::errc() && end == field.data() + n;
}

// an index: optional '-', 1 to 10 digits
bool parse_index(std::string_view field, int64_t& out) {
  size_t i = field.size() && field[0] == '-' ? 1 : 0;
  if (field.size() == i || field.size() - i > 10) return false;
  int64_t value = 0;
  for (; i < field.size(); ++i) {
    if (field[i] < '0' || field[i] > '9') return false;
    value = 10 * value + (field[i] - '0');
  }
  out = field[0] == '-' ? -value : value;
  return true;
}

// the fields of a line after its keyword
void split(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
}

enum class Form { unknown, v, v_vt, v__vn, v_vt_vn };

Form form_of(std::string_view corner) {
  const size_t a = corner.find('/');
  if (a == std::string_view::npos) return Form::v;
  const size_t b = corner.find('/', a + 1);
  if (b == std::string_view::npos) return Form::v_vt;
  if (corner.find('/', b + 1) != std::string_view::npos) return Form::unknown;
  return b == a + 1 ? Form::v__vn : Form::v_vt_vn;
}

struct Parsed {
  std::vector<double> v, vt;
  std::vector<int64_t> sizes;
  std::vector<int32_t> vi, ti;  // per corner, 0-based (a file of 2**31 elements or more is left to objfile.py)
  std::vector<int64_t> relative_v, relative_t;  // the corners of relative (negative) indices: a later piece's count from its start
  std::vector<std::string> mtllibs;
  // the g/o (kind 0) and usemtl (kind 1) lines: each one's name (its fields joined by a
  // space, as " ".join(line.split()[1:])) and the triangles before it (in this piece)
  std::vector<std::tuple<int, std::string, int64_t>> marks;
  int64_t triangles = 0;
  Form form = Form::unknown;
};

// a g/o or usemtl line's mark: fields[1:] joined by one space
void mark(Parsed& p, int kind, const std::vector<std::string_view>& fields) {
  std::string name;
  for (size_t k = 1; k < fields.size(); ++k) {
    if (k > 1) name += ' ';
    name.append(fields[k]);
  }
  p.marks.emplace_back(kind, std::move(name), p.triangles);
}

// one face line's corners into parsed (indices resolved against the elements so far)
bool face_line(const std::vector<std::string_view>& corners, int64_t v_so_far, int64_t vt_so_far, Parsed& p) {
  if (corners.size() < 3) return false;
  for (std::string_view corner : corners) {
    const Form form = form_of(corner);
    if (form == Form::unknown || (p.form != Form::unknown && form != p.form)) return false;
    p.form = form;
    const size_t a = corner.find('/');
    int64_t position, texcoord = 0, normal;
    if (!parse_index(corner.substr(0, a), position) || position == 0 || position > INT32_MAX || position < -INT32_MAX) return false;
    if (position < 0) p.relative_v.push_back(int64_t(p.vi.size()));
    p.vi.push_back(int32_t(position < 0 ? v_so_far + position : position - 1));
    if (form == Form::v_vt || form == Form::v_vt_vn) {
      const size_t b = corner.find('/', a + 1);
      if (!parse_index(corner.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1), texcoord) ||
          texcoord == 0 || texcoord > INT32_MAX || texcoord < -INT32_MAX)
        return false;
      if (texcoord < 0) p.relative_t.push_back(int64_t(p.ti.size()));
      p.ti.push_back(int32_t(texcoord < 0 ? vt_so_far + texcoord : texcoord - 1));
    }
    if ((form == Form::v__vn || form == Form::v_vt_vn) && !parse_index(corner.substr(corner.rfind('/') + 1), normal))
      return false;
  }
  p.sizes.push_back(int64_t(corners.size()));
  p.triangles += int64_t(corners.size()) - 2;
  return true;
}

// one line (leading spaces stripped, tabs as spaces): false where objfile.py must read the file
bool take_line(std::string_view line, Parsed& p, std::vector<std::string_view>& fields) {
  const char c0 = line.size() > 0 ? line[0] : '\0', c1 = line.size() > 1 ? line[1] : '\0';
  const char c2 = line.size() > 2 ? line[2] : '\0';
  if (c0 == 'v' && is_space(c1)) {
    split(line.substr(2), fields);
    if (fields.size() < 3) return false;
    double x;
    for (size_t k = 0; k < fields.size(); ++k) {
      if (!parse_number(fields[k], x)) return false;
      if (k < 3) p.v.push_back(x);
    }
  } else if (c0 == 'v' && c1 == 't' && (is_space(c2) || line.size() == 2)) {
    split(line.substr(2), fields);
    double x = 0.0, y = 0.0, value;  // missing ones are 0
    for (size_t k = 0; k < fields.size(); ++k) {
      if (!parse_number(fields[k], value)) return false;
      if (k == 0) x = value;
      if (k == 1) y = value;
    }
    p.vt.push_back(x);
    p.vt.push_back(y);
  } else if (c0 == 'f' && is_space(c1)) {
    split(line.substr(2), fields);
    if (!face_line(fields, int64_t(p.v.size() / 3), int64_t(p.vt.size() / 2), p)) return false;
  } else if (c0 == 'm' && c1 == 't') {
    split(line, fields);
    if (fields[0] == "mtllib") {
      for (size_t k = 1; k < fields.size(); ++k) p.mtllibs.emplace_back(fields[k]);
    }
  } else if ((c0 == 'g' || c0 == 'o') && (is_space(c1) || line.size() == 1)) {
    split(line, fields);
    mark(p, 0, fields);
  } else if (c0 == 'u' && c1 == 's') {
    split(line, fields);
    if (fields[0] == "usemtl") mark(p, 1, fields);
  }
  return true;
}

// the arrays' room, from a count of the lines by their first bytes (growing them by doubling
// would allocate, and the kernel zero, twice the memory)
void reserve(std::string_view data, Parsed& p) {
  size_t v = 0, vt = 0, f = 0;
  for (size_t i = 0; i < data.size();) {
    size_t start = i;
    while (start < data.size() && is_space(data[start])) ++start;
    const char c0 = start < data.size() ? data[start] : '\0', c1 = start + 1 < data.size() ? data[start + 1] : '\0';
    v += c0 == 'v' && is_space(c1);
    vt += c0 == 'v' && c1 == 't';
    f += c0 == 'f' && is_space(c1);
    const void* end = std::memchr(data.data() + start, '\n', data.size() - start);
    i = end ? size_t(static_cast<const char*>(end) - data.data()) + 1 : data.size();
  }
  p.v.reserve(3 * v);
  p.vt.reserve(2 * vt);
  p.sizes.reserve(f);
  p.vi.reserve(3 * f);
  if (vt) p.ti.reserve(3 * f);
}

// the lines of one piece of the file (relative indices counted from the piece's start)
bool parse_lines(std::string_view data, Parsed& p) {
  for (unsigned char c : data) {  // bytes str.split() or str.splitlines() would break at, or beyond ASCII
    if (c >= 0x80 || c == 0x0b || c == 0x0c || (c >= 0x1c && c <= 0x1f)) return false;
  }
  reserve(data, p);
  std::vector<std::string_view> fields;
  size_t i = 0;
  while (i < data.size()) {
    size_t end = i;
    while (end < data.size() && data[end] != '\n' && data[end] != '\r') ++end;
    size_t start = i;
    while (start < end && is_space(data[start])) ++start;
    if (!take_line(data.substr(start, end - start), p, fields)) return false;
    i = end + (end + 1 < data.size() && data[end] == '\r' && data[end + 1] == '\n' ? 2 : 1);
  }
  return true;
}

// the second piece after the first: its relative indices moved by the first's elements
bool append(Parsed& p, Parsed& second) {
  if (p.form != Form::unknown && second.form != Form::unknown && p.form != second.form) return false;
  if (p.form == Form::unknown) p.form = second.form;
  const int64_t nv = int64_t(p.v.size() / 3), nvt = int64_t(p.vt.size() / 2);
  if (nv + int64_t(second.v.size() / 3) > INT32_MAX || nvt + int64_t(second.vt.size() / 2) > INT32_MAX) return false;
  for (int64_t c : second.relative_v) second.vi[c] = int32_t(second.vi[c] + nv);  // within [-2**31, 2**31): checked after
  for (int64_t c : second.relative_t) second.ti[c] = int32_t(second.ti[c] + nvt);
  p.v.insert(p.v.end(), second.v.begin(), second.v.end());
  p.vt.insert(p.vt.end(), second.vt.begin(), second.vt.end());
  p.sizes.insert(p.sizes.end(), second.sizes.begin(), second.sizes.end());
  p.vi.insert(p.vi.end(), second.vi.begin(), second.vi.end());
  p.ti.insert(p.ti.end(), second.ti.begin(), second.ti.end());
  p.mtllibs.insert(p.mtllibs.end(), second.mtllibs.begin(), second.mtllibs.end());
  for (auto& [kind, name, before] : second.marks) p.marks.emplace_back(kind, std::move(name), before + p.triangles);
  p.triangles += second.triangles;
  return true;
}

// A file of megabytes is read in two pieces at once, cut at a line's end.
constexpr size_t TWO_PIECES = 1 << 22;

bool parse(std::string_view data, Parsed& p) {
  const size_t half = data.size() / 2;
  const size_t cut = data.size() < TWO_PIECES ? std::string_view::npos : data.find('\n', half);
  if (cut == std::string_view::npos) {
    if (!parse_lines(data, p)) return false;
  } else {
    Parsed second;
    bool second_ok = false;
    std::thread other([&] { second_ok = parse_lines(data.substr(cut + 1), second); });
    const bool first_ok = parse_lines(data.substr(0, cut + 1), p);
    other.join();
    if (!first_ok || !second_ok || !append(p, second)) return false;
  }
  const int64_t nv = int64_t(p.v.size() / 3), nvt = int64_t(p.vt.size() / 2);
  for (int32_t x : p.vi) {
    if (x < 0 || x >= nv) return false;
  }
  for (int32_t x : p.ti) {
    if (x < 0 || x >= nvt) return false;
  }
  return true;
}

// number[c] := corner c's new vertex, one per distinct (position, texcoord) pair in order of
// first use; returns each new vertex's first corner. The texcoord alone is the key where each
// is used with one position (a table, not a hash)
std::vector<int64_t> number_corners(const Parsed& p, std::vector<int64_t>& number) {
  const bool has_uv = !p.ti.empty();
  const int64_t corners = int64_t(p.vi.size()), nv = int64_t(p.v.size() / 3), nvt = int64_t(p.vt.size() / 2);
  std::vector<int64_t> first;
  auto by_table = [&](const std::vector<int32_t>& key, int64_t size) {
    std::vector<int64_t> seen(size, -1);
    for (int64_t c = 0; c < corners; ++c) {
      int64_t& s = seen[key[c]];
      if (s < 0) {
        s = int64_t(first.size());
        first.push_back(c);
      }
      number[c] = s;
    }
  };
  bool one_position = has_uv;
  if (has_uv) {
    std::vector<int32_t> owner(nvt, -1);
    for (int64_t c = 0; c < corners && one_position; ++c) {
      int32_t& o = owner[p.ti[c]];
      one_position = o < 0 || o == p.vi[c];
      o = p.vi[c];
    }
  }
  if (!has_uv) {
    by_table(p.vi, nv);
  } else if (one_position) {
    by_table(p.ti, nvt);
  } else {  // (position, texcoord) pairs
    std::unordered_map<uint64_t, int64_t> pairs;
    pairs.reserve(size_t(corners));
    for (int64_t c = 0; c < corners; ++c) {
      const auto [at, added] = pairs.try_emplace(uint64_t(p.vi[c]) * uint64_t(nvt) + uint64_t(p.ti[c]), int64_t(first.size()));
      if (added) first.push_back(c);
      number[c] = at->second;
    }
  }
  return first;
}

// fan triangles over the polygons, and the new vertices' positions and UVs
void build(const Parsed& p, std::vector<double>& vertices, std::vector<int64_t>& faces, std::vector<double>& uv) {
  const bool has_uv = !p.ti.empty();
  std::vector<int64_t> number(p.vi.size());  // each corner's new vertex: the faces themselves when all are triangles
  const std::vector<int64_t> first = number_corners(p, number);
  vertices.resize(3 * first.size());
  if (has_uv) uv.resize(2 * first.size());
  for (size_t k = 0; k < first.size(); ++k) {
    const int64_t c = first[k];
    for (int j = 0; j < 3; ++j) vertices[3 * k + j] = p.v[3 * size_t(p.vi[c]) + j];
    if (has_uv) {
      uv[2 * k] = p.vt[2 * size_t(p.ti[c])];
      uv[2 * k + 1] = p.vt[2 * size_t(p.ti[c]) + 1];
    }
  }
  if (p.vi.size() == 3 * p.sizes.size()) {  // every polygon a triangle (none has fewer corners)
    faces = std::move(number);
    return;
  }
  int64_t start = 0;
  for (int64_t size : p.sizes) {
    for (int64_t k = 1; k + 1 < size; ++k) {
      faces.push_back(number[start]);
      faces.push_back(number[start + k]);
      faces.push_back(number[start + k + 1]);
    }
    start += size;
  }
}

using Doubles = nb::ndarray<nb::numpy, double>;
using Ints = nb::ndarray<nb::numpy, int64_t>;
using Marks = std::vector<std::tuple<int, std::string, int64_t>>;
using Mesh = std::tuple<std::vector<std::string>, Doubles, Ints, std::optional<Doubles>, Marks>;

std::optional<Mesh> read_text(std::string_view text) {
  Parsed p;
  std::vector<double> vertices, uv;
  std::vector<int64_t> faces;
  {
    nb::gil_scoped_release unlocked;
    if (!parse(text, p)) return std::nullopt;
    if (p.sizes.empty()) {  // no faces: the positions as they are
      vertices = std::move(p.v);
    } else {
      build(p, vertices, faces, uv);
    }
  }
  const size_t n = vertices.size() / 3, m = faces.size() / 3;
  std::optional<Doubles> texcoords;
  if (!p.ti.empty()) texcoords = owned(std::move(uv), {n, 2});
  return Mesh{std::move(p.mtllibs), owned(std::move(vertices), {n, 3}), owned(std::move(faces), {m, 3}), std::move(texcoords),
              std::move(p.marks)};
}

std::optional<Mesh> read_array(In<uint8_t, nb::ndim<1>> data) {
  return read_text(std::string_view(reinterpret_cast<const char*>(data.data()), data.shape(0)));
}

std::optional<Mesh> read_bytes(nb::bytes data) { return read_text(std::string_view(data.c_str(), data.size())); }

}  // namespace

void bind_objfile(nb::module_& m) {
  m.def("read_obj", &read_bytes, nb::arg("data"));
  m.def("read_obj", &read_array, nb::arg("data"),
        "(mtllib names, vertices (n, 3) float64, faces (m, 3) int64, uv (n, 2) float64 or None, marks: (kind 0 g/o or 1 "
        "usemtl, name, triangles before it) of each g/o and usemtl line) of OBJ bytes (uint8), or None "
        "where texbake.mesh.objfile's own readers must read them.");
}

}  // namespace texbake
