// Reading and writing triangle meshes and index lists. Pure I/O: no validation of geometry beyond
// what the format needs (use ValidateMesh for that).
//
// Formats: OBJ (`v x y z` and `f a b c` lines, 1-based or negative indices, `a/b/c` corners accepted,
// polygons fan-triangulated) and PLY (ascii or binary_little_endian; vertex x, y, z and a face list).
// Errors name the file and the line (OBJ, text) or element (PLY).
#pragma once

#include <Eigen/Core>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

// Reads an .obj or .ply file (chosen by extension, case-insensitive).
Result<TriMesh> ReadMesh(const std::string& path);

// The same from a file's bytes in memory (e.g. a file sent with a job); `name`, a file name, chooses
// the format by its extension and prefixes the messages. CheckMeshBytes first.
Result<TriMesh> ParseMesh(std::string_view content, const std::string& name);

// Whether a file's bytes can be the mesh its name says (.obj or .ply), from its first 4 KB: a PLY file's
// first line is "ply"; an OBJ file is text (UTF-8 without control characters) whose first statement is
// one of OBJ's (v, f, vn, vt, o, g, s, usemtl, mtllib; # comments and blank lines aside). The message
// names the file and quotes the line, escaped and cut to 40 bytes, e.g. `photo.obj is not an OBJ or
// PLY mesh (line 1: "\x89PNG" is not text)`. The design service checks every mesh sent with a job with
// it when the job is submitted, before any worker parses it.
Status CheckMeshBytes(std::string_view content, const std::string& name);

// Per-face scalar attributes written after the vertex indices of each face.
struct FaceProperty {
  std::string name;
  Eigen::VectorXd values;  // one per face
  bool as_uchar = false;   // store as an 8-bit integer (e.g. a design bit) instead of a double
};

// Writes binary little-endian PLY with double vertex coordinates and optional per-face properties.
Status WritePly(const std::string& path, const Positions& x, const Faces& faces,
                const std::vector<FaceProperty>& face_properties = {});

// The same PLY to a stream (e.g. an HTTP download); `name` is for messages.
Status WritePly(std::ostream& out, const std::string& name, const Positions& x, const Faces& faces,
                const std::vector<FaceProperty>& face_properties = {});

// A garment's result as PLY, the one layout every kgd command and download writes: the positions, and
// per face `design` (uchar, 1 = reinforced) and `energy_density_Pa` (double, J/m^3). `design` and
// `energy_density_Pa` have one value per face.
Status WriteGarmentPly(const std::string& path, const Positions& x, const Faces& faces, const std::vector<uint8_t>& design,
                       const Eigen::VectorXd& energy_density_Pa);
Status WriteGarmentPly(std::ostream& out, const std::string& name, const Positions& x, const Faces& faces, const std::vector<uint8_t>& design,
                       const Eigen::VectorXd& energy_density_Pa);

// Writes an OBJ file (vertices with 17 significant digits: doubles round-trip, 1-based faces).
Status WriteObj(const std::string& path, const Positions& x, const Faces& faces);
// The same OBJ to a stream (e.g. an HTTP download); `name` is for messages.
Status WriteObj(std::ostream& out, const std::string& name, const Positions& x, const Faces& faces);

// Reads a text file of integers, one per line (blank lines and lines starting with '#' ignored).
// Errors name the file and the line.
Result<std::vector<int>> ReadIndexList(const std::string& path);

// The same from a file's bytes in memory; `name` prefixes the messages.
Result<std::vector<int>> ParseIndexList(std::string_view content, const std::string& name);

}  // namespace kgd
