#include "core/mesh/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>

namespace kgd {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Where(const std::string& path, size_t line) { return path + ":" + std::to_string(line) + ": "; }

// Length of the UTF-8 sequence starting at text[i] (0: not one).
size_t Utf8Length(std::string_view text, size_t i) {
  const unsigned char c = static_cast<unsigned char>(text[i]);
  const size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
  if (n == 0 || i + n > text.size()) return 0;
  for (size_t k = 1; k < n; ++k)
    if ((static_cast<unsigned char>(text[i + k]) >> 6) != 0x2) return 0;
  return n;
}

// A line of a file as messages quote it: at most 40 bytes, bytes that are not printable text as \xNN.
std::string Quoted(std::string_view line) {
  std::string out;
  const size_t n = std::min<size_t>(line.size(), 40);
  for (size_t i = 0; i < n;) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    const size_t len = Utf8Length(line, i);
    if (c >= 0x20 && c != 0x7f && len == 1) {
      out += c == '"' || c == '\\' ? std::string("\\") + static_cast<char>(c) : std::string(1, static_cast<char>(c));
      ++i;
    } else if (len > 1) {
      out.append(line.substr(i, len));
      i += len;
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
      ++i;
    }
  }
  return out + (line.size() > n ? "..." : "");
}

// True when `line` is text: UTF-8 without control characters (tabs and form feeds aside).
bool IsTextLine(std::string_view line) {
  for (size_t i = 0; i < line.size();) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    const size_t len = Utf8Length(line, i);
    if (len == 0 || (c < 0x20 && c != '\t' && c != '\r' && c != '\f' && c != '\v') || c == 0x7f) return false;
    i += len;
  }
  return true;
}

bool ParseDouble(std::string_view token, double* out) {
  const char* begin = token.data();
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(begin, end, *out);
  return ec == std::errc() && ptr == end;
}

bool ParseInt(std::string_view token, long* out) {
  const char* begin = token.data();
  const char* end = token.data() + token.size();
  if (begin != end && *begin == '+') ++begin;
  auto [ptr, ec] = std::from_chars(begin, end, *out);
  return ec == std::errc() && ptr == end;
}

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// The whitespace-separated words of one line (views into it).
int SplitLine(std::string_view line, std::vector<std::string_view>* words) {
  words->clear();
  size_t i = 0;
  while (true) {
    while (i < line.size() && IsSpace(line[i])) ++i;
    if (i == line.size()) break;
    const size_t start = i;
    while (i < line.size() && !IsSpace(line[i])) ++i;
    words->push_back(line.substr(start, i - start));
  }
  return static_cast<int>(words->size());
}

// A whole file's bytes.
Result<std::string> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return Status::Error(path + ": cannot open file");
  std::string bytes(static_cast<size_t>(std::max<std::streamoff>(0, in.tellg())), '\0');
  in.seekg(0);
  if (!in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()))) return Status::Error(path + ": cannot read file");
  return bytes;
}

// The whole file at once, split into lines and words by hand: a scene's bodies are tens of MB of OBJ,
// and a stream per line costs several times the parsing itself.
Result<TriMesh> ParseObj(std::string_view text, const std::string& path) {
  std::vector<Eigen::Vector3d> verts;
  std::vector<Eigen::Vector3i> tris;
  size_t line_no = 0;
  std::vector<std::string_view> w;
  std::vector<int> corners;
  for (size_t pos = 0; pos < text.size();) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    std::string_view line(text.data() + pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const int nw = SplitLine(line, &w);
    if (nw == 0 || w[0][0] == '#') continue;
    if (w[0] == "v") {
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k) {
        if (k + 1 >= nw || !ParseDouble(w[k + 1], &p[k]))
          return Status::Error(Where(path, line_no) + "vertex " + std::to_string(verts.size()) + ": expected three numbers, got '" +
                               Quoted(line) + "'");
        if (!std::isfinite(p[k]))
          return Status::Error(Where(path, line_no) + "vertex " + std::to_string(verts.size()) + " has a non-finite coordinate '" +
                               Quoted(w[k + 1]) + "'");
      }
      verts.push_back(p);
    } else if (w[0] == "f") {
      corners.clear();
      for (int k = 1; k < nw; ++k) {
        const std::string_view first = w[k].substr(0, w[k].find('/'));
        long idx = 0;
        if (!ParseInt(first, &idx) || idx == 0)
          return Status::Error(Where(path, line_no) + "face " + std::to_string(tris.size()) + ": bad vertex index '" + Quoted(w[k]) + "'");
        // OBJ indices are 1-based; negative ones count back from the last vertex read so far.
        const long zero_based = idx > 0 ? idx - 1 : static_cast<long>(verts.size()) + idx;
        if (zero_based < 0 || zero_based > INT32_MAX)
          return Status::Error(Where(path, line_no) + "face " + std::to_string(tris.size()) + ": vertex index " + std::to_string(idx) +
                               " out of range");
        corners.push_back(static_cast<int>(zero_based));
      }
      if (corners.size() < 3)
        return Status::Error(Where(path, line_no) + "face " + std::to_string(tris.size()) + " has " + std::to_string(corners.size()) +
                             " corners, need at least 3");
      for (size_t k = 1; k + 1 < corners.size(); ++k) tris.emplace_back(corners[0], corners[k], corners[k + 1]);
    }
    // Other tags (vn, vt, o, g, s, usemtl, mtllib, l) carry nothing the simulator uses.
  }
  TriMesh mesh;
  mesh.vertices.resize(verts.size(), 3);
  for (size_t i = 0; i < verts.size(); ++i) mesh.vertices.row(i) = verts[i].transpose();
  mesh.faces.resize(tris.size(), 3);
  for (size_t i = 0; i < tris.size(); ++i) mesh.faces.row(i) = tris[i].transpose();
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces(f, k) >= mesh.vertices.rows())
        return Status::Error(path + ": face " + std::to_string(f) + " refers to vertex " +
                             std::to_string(mesh.faces(f, k) + 1) + " (1-based) but the file has " +
                             std::to_string(mesh.vertices.rows()) + " vertices");
  return mesh;
}

// --- PLY ---

enum class PlyType { kChar, kUChar, kShort, kUShort, kInt, kUInt, kFloat, kDouble, kInvalid };

PlyType ParsePlyType(const std::string& s) {
  if (s == "char" || s == "int8") return PlyType::kChar;
  if (s == "uchar" || s == "uint8") return PlyType::kUChar;
  if (s == "short" || s == "int16") return PlyType::kShort;
  if (s == "ushort" || s == "uint16") return PlyType::kUShort;
  if (s == "int" || s == "int32") return PlyType::kInt;
  if (s == "uint" || s == "uint32") return PlyType::kUInt;
  if (s == "float" || s == "float32") return PlyType::kFloat;
  if (s == "double" || s == "float64") return PlyType::kDouble;
  return PlyType::kInvalid;
}

int PlyTypeSize(PlyType t) {
  switch (t) {
    case PlyType::kChar: case PlyType::kUChar: return 1;
    case PlyType::kShort: case PlyType::kUShort: return 2;
    case PlyType::kInt: case PlyType::kUInt: case PlyType::kFloat: return 4;
    case PlyType::kDouble: return 8;
    default: return 0;
  }
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kInvalid;
  bool is_list = false;
  PlyType count_type = PlyType::kInvalid;
};

struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> props;
};

// Reads one binary value of the given type; returns false at end of data.
bool ReadBinary(std::istream& in, PlyType t, double* out) {
  unsigned char buf[8];
  const int n = PlyTypeSize(t);
  if (!in.read(reinterpret_cast<char*>(buf), n)) return false;
  switch (t) {
    case PlyType::kChar: *out = static_cast<int8_t>(buf[0]); break;
    case PlyType::kUChar: *out = buf[0]; break;
    case PlyType::kShort: { int16_t v; std::memcpy(&v, buf, 2); *out = v; break; }
    case PlyType::kUShort: { uint16_t v; std::memcpy(&v, buf, 2); *out = v; break; }
    case PlyType::kInt: { int32_t v; std::memcpy(&v, buf, 4); *out = v; break; }
    case PlyType::kUInt: { uint32_t v; std::memcpy(&v, buf, 4); *out = v; break; }
    case PlyType::kFloat: { float v; std::memcpy(&v, buf, 4); *out = v; break; }
    case PlyType::kDouble: { double v; std::memcpy(&v, buf, 8); *out = v; break; }
    default: return false;
  }
  return true;
}

Result<TriMesh> ParsePly(std::string_view content, const std::string& path) {
  std::istringstream in(std::string(content), std::ios::binary);
  const long file_bytes = static_cast<long>(content.size());
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != "ply") return Status::Error(path + ":1: not a PLY file (first line is not 'ply')");
  bool binary = false;
  std::vector<PlyElement> elements;
  size_t line_no = 1;
  bool header_done = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string fmt;
      ls >> fmt;
      if (fmt == "ascii") binary = false;
      else if (fmt == "binary_little_endian") binary = true;
      else return Status::Error(Where(path, line_no) + "unsupported PLY format '" + Quoted(fmt) + "'");
    } else if (kw == "element") {
      PlyElement e;
      std::string count, extra;
      ls >> e.name >> count;
      if (!ls || !ParseInt(count, &e.count) || e.count < 0 || (ls >> extra))
        return Status::Error(Where(path, line_no) + "bad element line '" + Quoted(line) + "'");
      // Every element takes at least a byte: a count beyond the file's size is a corrupt header, and
      // would otherwise be allocated before the data runs out.
      if (e.count > file_bytes)
        return Status::Error(Where(path, line_no) + "element '" + e.name + "' declares " + count +
                             " entries but the file has only " + std::to_string(file_bytes) + " bytes");
      elements.push_back(e);
    } else if (kw == "property") {
      if (elements.empty()) return Status::Error(Where(path, line_no) + "property before any element");
      PlyProperty p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        p.is_list = true;
        p.count_type = ParsePlyType(ct);
        p.type = ParsePlyType(it);
      } else {
        p.type = ParsePlyType(t);
        ls >> p.name;
      }
      if (p.type == PlyType::kInvalid || (p.is_list && p.count_type == PlyType::kInvalid))
        return Status::Error(Where(path, line_no) + "unknown property type in '" + Quoted(line) + "'");
      elements.back().props.push_back(p);
    } else if (kw == "end_header") {
      header_done = true;
      break;
    }
    // comment, obj_info: ignored.
  }
  if (!header_done) return Status::Error(path + ": PLY header has no end_header");

  TriMesh mesh;
  std::vector<Eigen::Vector3i> tris;
  bool have_vertices = false;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, iface = -1;
    for (size_t k = 0; k < e.props.size(); ++k) {
      const auto& n = e.props[k].name;
      if (n == "x") ix = k; else if (n == "y") iy = k; else if (n == "z") iz = k;
      else if (e.props[k].is_list && (n == "vertex_indices" || n == "vertex_index")) iface = k;
    }
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0))
      return Status::Error(path + ": PLY vertex element lacks x, y or z");
    if (is_face && iface < 0) return Status::Error(path + ": PLY face element lacks a vertex_indices list");
    if (is_vertex) { mesh.vertices.resize(e.count, 3); have_vertices = true; }
    for (long i = 0; i < e.count; ++i) {
      std::istringstream ls;
      if (!binary) {
        if (!std::getline(in, line))
          return Status::Error(path + ": unexpected end of file in " + e.name + " " + std::to_string(i));
        ls.str(line);
      }
      auto read_value = [&](PlyType t, double* v) -> bool {
        if (binary) return ReadBinary(in, t, v);
        std::string tok;
        return static_cast<bool>(ls >> tok) && ParseDouble(tok, v);
      };
      for (size_t k = 0; k < e.props.size(); ++k) {
        const PlyProperty& p = e.props[k];
        if (!p.is_list) {
          double v;
          if (!read_value(p.type, &v))
            return Status::Error(path + ": " + e.name + " " + std::to_string(i) + ": cannot read property '" +
                                 p.name + "'");
          if (is_vertex) {
            if (static_cast<int>(k) == ix) mesh.vertices(i, 0) = v;
            if (static_cast<int>(k) == iy) mesh.vertices(i, 1) = v;
            if (static_cast<int>(k) == iz) mesh.vertices(i, 2) = v;
            if ((static_cast<int>(k) == ix || static_cast<int>(k) == iy || static_cast<int>(k) == iz) &&
                !std::isfinite(v))
              return Status::Error(path + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
          }
          continue;
        }
        // Written as "not inside" so that NaN fails too; a double outside int's range must not be cast.
        double count_d;
        if (!read_value(p.count_type, &count_d) || !(count_d >= 0 && count_d <= 1e6) || count_d != std::floor(count_d))
          return Status::Error(path + ": " + e.name + " " + std::to_string(i) + ": bad list length");
        const int count = static_cast<int>(count_d);
        std::vector<int> idx(count);
        for (int c = 0; c < count; ++c) {
          double v;
          if (!read_value(p.type, &v))
            return Status::Error(path + ": " + e.name + " " + std::to_string(i) + ": cannot read list entry");
          if (!is_face || static_cast<int>(k) != iface) continue;  // another list (texture coordinates, ...)
          if (!(v >= INT32_MIN && v <= INT32_MAX) || v != std::floor(v)) {
            std::ostringstream m;
            m << path << ": face " << i << ": vertex index " << v << " is not an integer";
            return Status::Error(m.str());
          }
          idx[c] = static_cast<int>(v);
        }
        if (is_face && static_cast<int>(k) == iface) {
          if (count < 3)
            return Status::Error(path + ": face " + std::to_string(i) + " has " + std::to_string(count) +
                                 " corners, need at least 3");
          for (int c = 1; c + 1 < count; ++c) tris.emplace_back(idx[0], idx[c], idx[c + 1]);
        }
      }
    }
  }
  if (!have_vertices) return Status::Error(path + ": PLY file has no vertex element");
  mesh.faces.resize(tris.size(), 3);
  for (size_t i = 0; i < tris.size(); ++i) {
    for (int k = 0; k < 3; ++k)
      if (tris[i][k] < 0 || tris[i][k] >= mesh.vertices.rows())
        return Status::Error(path + ": face " + std::to_string(i) + " refers to vertex " +
                             std::to_string(tris[i][k]) + ", out of range [0, " +
                             std::to_string(mesh.vertices.rows()) + ")");
    mesh.faces.row(i) = tris[i].transpose();
  }
  return mesh;
}

// The mesh format named by a file's extension (case-insensitive).
Result<bool> IsObjName(const std::string& name) {
  const std::string lower = Lower(name);
  if (EndsWith(lower, ".obj") || EndsWith(lower, ".ply")) return EndsWith(lower, ".obj");
  return Status::Error(name + ": unknown mesh format (expected .obj or .ply)");
}

}  // namespace

Status CheckMeshBytes(std::string_view content, const std::string& name) {
  Result<bool> obj = IsObjName(name);
  if (!obj.ok()) return obj.status();
  auto refused = [&](size_t line_no, std::string_view line, const std::string& what) {
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return Status::Error(name + " is not an OBJ or PLY mesh (line " + std::to_string(line_no) + ": \"" + Quoted(line) + "\" " + what + ")");
  };
  const std::string_view first = content.substr(0, content.find('\n'));
  if (!*obj) {
    if (first != "ply" && first != "ply\r") return refused(1, first, IsTextLine(first) ? "is not \"ply\", a PLY file's first line" : "is not text");
    return Status::Ok();
  }
  // The OBJ statements kgd reads or skips; the first line of any other text says what the file is.
  static const char* const kStatements[] = {"v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "usemtl", "mtllib"};
  const std::string_view head = content.substr(0, 4096);
  bool statement_seen = false;
  size_t line_no = 0;
  for (size_t pos = 0; pos < head.size();) {
    size_t eol = head.find('\n', pos);
    // A last line cut at 4096 bytes may end inside a character: it is checked up to its last whole one.
    const bool cut = eol == std::string::npos && head.size() < content.size();
    if (eol == std::string::npos) eol = head.size();
    std::string_view line = head.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (line_no == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // a byte-order mark
    if (cut) while (!line.empty() && (static_cast<unsigned char>(line.back()) & 0xC0) == 0x80) line.remove_suffix(1);
    if (cut && !line.empty() && static_cast<unsigned char>(line.back()) >= 0xC0) line.remove_suffix(1);
    if (!IsTextLine(line)) return refused(line_no, line, "is not text");
    if (statement_seen) continue;
    std::vector<std::string_view> words;
    if (SplitLine(line, &words) == 0 || words[0][0] == '#') continue;
    bool known = false;
    for (const char* k : kStatements) known |= words[0] == k;
    if (!known) return refused(line_no, line, "is not an OBJ statement (v, f, vn, vt, o, g, s, usemtl, mtllib, # ...)");
    statement_seen = true;
  }
  return Status::Ok();
}

Result<TriMesh> ParseMesh(std::string_view content, const std::string& name) {
  KGD_RETURN_IF_ERROR(CheckMeshBytes(content, name));
  Result<bool> obj = IsObjName(name);
  if (!obj.ok()) return obj.status();
  return *obj ? ParseObj(content, name) : ParsePly(content, name);
}

Result<TriMesh> ReadMesh(const std::string& path) {
  // A folder opens as a stream, and its size reads as anything.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return Status::Error(path + ": is a folder, not a mesh file");
  if (Result<bool> obj = IsObjName(path); !obj.ok()) return obj.status();
  Result<std::string> bytes = ReadBytes(path);
  if (!bytes.ok()) return bytes.status();
  return ParseMesh(*bytes, path);
}

Status WritePly(const std::string& path, const Positions& x, const Faces& faces,
                const std::vector<FaceProperty>& face_properties) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return Status::Error(path + ": cannot open for writing");
  return WritePly(out, path, x, faces, face_properties);
}

namespace {

std::vector<FaceProperty> GarmentFaceProperties(const std::vector<uint8_t>& design, const Eigen::VectorXd& energy_density_Pa) {
  Eigen::VectorXd d(static_cast<Eigen::Index>(design.size()));
  for (size_t f = 0; f < design.size(); ++f) d[static_cast<Eigen::Index>(f)] = design[f];
  return {{"design", d, true}, {"energy_density_Pa", energy_density_Pa, false}};
}

}  // namespace

Status WriteGarmentPly(const std::string& path, const Positions& x, const Faces& faces, const std::vector<uint8_t>& design,
                       const Eigen::VectorXd& energy_density_Pa) {
  return WritePly(path, x, faces, GarmentFaceProperties(design, energy_density_Pa));
}

Status WriteGarmentPly(std::ostream& out, const std::string& name, const Positions& x, const Faces& faces, const std::vector<uint8_t>& design,
                       const Eigen::VectorXd& energy_density_Pa) {
  return WritePly(out, name, x, faces, GarmentFaceProperties(design, energy_density_Pa));
}

Status WritePly(std::ostream& out, const std::string& path, const Positions& x, const Faces& faces,
                const std::vector<FaceProperty>& face_properties) {
  for (const auto& p : face_properties)
    if (p.values.size() != faces.rows())
      return Status::Error(path + ": face property '" + p.name + "' has " + std::to_string(p.values.size()) +
                           " values for " + std::to_string(faces.rows()) + " faces");
  out << "ply\nformat binary_little_endian 1.0\ncomment kgd output, units: metres\n";
  out << "element vertex " << x.rows() << "\nproperty double x\nproperty double y\nproperty double z\n";
  out << "element face " << faces.rows() << "\nproperty list uchar int vertex_indices\n";
  for (const auto& p : face_properties) out << "property " << (p.as_uchar ? "uchar " : "double ") << p.name << "\n";
  out << "end_header\n";
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    for (int k = 0; k < 3; ++k) {
      const double d = x(v, k);
      out.write(reinterpret_cast<const char*>(&d), 8);
    }
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const unsigned char three = 3;
    out.write(reinterpret_cast<const char*>(&three), 1);
    for (int k = 0; k < 3; ++k) {
      const int32_t i = faces(f, k);
      out.write(reinterpret_cast<const char*>(&i), 4);
    }
    for (const auto& p : face_properties) {
      if (p.as_uchar) {
        const unsigned char b = static_cast<unsigned char>(std::clamp(p.values[f], 0.0, 255.0));
        out.write(reinterpret_cast<const char*>(&b), 1);
      } else {
        const double d = p.values[f];
        out.write(reinterpret_cast<const char*>(&d), 8);
      }
    }
  }
  if (!out) return Status::Error(path + ": write failed");
  return Status::Ok();
}

Status WriteObj(const std::string& path, const Positions& x, const Faces& faces) {
  std::ofstream out(path);
  if (!out) return Status::Error(path + ": cannot open for writing");
  return WriteObj(out, path, x, faces);
}

Status WriteObj(std::ostream& out, const std::string& path, const Positions& x, const Faces& faces) {
  out.precision(17);  // round-trips doubles exactly: an exported scene reproduces its source
  for (Eigen::Index v = 0; v < x.rows(); ++v) out << "v " << x(v, 0) << ' ' << x(v, 1) << ' ' << x(v, 2) << '\n';
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    out << "f " << faces(f, 0) + 1 << ' ' << faces(f, 1) + 1 << ' ' << faces(f, 2) + 1 << '\n';
  if (!out) return Status::Error(path + ": write failed");
  return Status::Ok();
}

Result<std::vector<int>> ReadIndexList(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open file");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return ParseIndexList(bytes.str(), path);
}

Result<std::vector<int>> ParseIndexList(std::string_view content, const std::string& path) {
  std::istringstream in{std::string(content)};
  std::vector<int> out;
  std::string line;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t");
    long v;
    if (!ParseInt(line.substr(first, last - first + 1), &v) || v < INT32_MIN || v > INT32_MAX)
      return Status::Error(Where(path, line_no) + "expected one integer, got '" + Quoted(line) + "'");
    out.push_back(static_cast<int>(v));
  }
  return out;
}

}  // namespace kgd
