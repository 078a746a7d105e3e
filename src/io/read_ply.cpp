// PLY, ASCII and binary (little and big endian): element "vertex" with scalar x, y, z of any
// numeric type; element "face" with a list "vertex_indices" (or "vertex_index") of any integer
// count and index types, fan-triangulated. Every other element and property is read past, in
// both encodings. Counts are checked against the bytes left before reserving, list lengths
// before reading them, every index against the vertex count, and the data must end exactly where
// the header says (a binary PLY of the wrong length is an error).
#include "binary_codec.h"
#include "surface_readers.h"
#include "text_scanner.h"

#include <gshell/error.h>

#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace gshell::io_detail {

namespace {

enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<Scalar> scalar_from_name(std::string_view name) {
  if (name == "char" || name == "int8") return Scalar::Int8;
  if (name == "uchar" || name == "uint8") return Scalar::UInt8;
  if (name == "short" || name == "int16") return Scalar::Int16;
  if (name == "ushort" || name == "uint16") return Scalar::UInt16;
  if (name == "int" || name == "int32") return Scalar::Int32;
  if (name == "uint" || name == "uint32") return Scalar::UInt32;
  if (name == "float" || name == "float32") return Scalar::Float32;
  if (name == "double" || name == "float64") return Scalar::Float64;
  return std::nullopt;
}

int scalar_size(Scalar t) {
  switch (t) {
  case Scalar::Int8: case Scalar::UInt8: return 1;
  case Scalar::Int16: case Scalar::UInt16: return 2;
  case Scalar::Int32: case Scalar::UInt32: case Scalar::Float32: return 4;
  case Scalar::Float64: return 8;
  }
  return 0;
}

bool is_float(Scalar t) { return t == Scalar::Float32 || t == Scalar::Float64; }

struct Property {
  std::string name;
  Scalar type = Scalar::Float32;   ///< value type (item type for lists)
  bool is_list = false;
  Scalar count_type = Scalar::UInt8;
};

struct Element {
  std::string name;
  long long count = 0;
  std::vector<Property> properties;
  int line = 0; ///< header line, for messages
};

enum class Encoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::vector<Element> elements;
  std::size_t body_offset = 0;
  int body_line = 1;
};

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t begin = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > begin) words.push_back(line.substr(begin, i - begin));
  }
  return words;
}

Header parse_header(const std::string& path, std::string_view bytes) {
  Header h;
  std::size_t pos = 0;
  int line_number = 0;
  auto fail = [&](const std::string& what) -> void {
    throw InputError(with_file(path, what + " (line " + std::to_string(line_number) + ")"));
  };
  bool have_format = false, ended = false;
  while (!ended) {
    if (pos >= bytes.size()) {
      if (bytes.empty()) throw InputError(with_file(path, "empty file, expected a PLY header"));
      fail("header has no 'end_header' (truncated or not a PLY file)");
    }
    const std::size_t eol = bytes.find('\n', pos);
    const std::size_t end = eol == std::string_view::npos ? bytes.size() : eol;
    const std::string_view line = bytes.substr(pos, end - pos);
    pos = eol == std::string_view::npos ? bytes.size() : eol + 1;
    ++line_number;
    for (char c : line)
      if ((static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\r') || c == 0x7f)
        fail(line_number == 1 ? "not a PLY file (first line must be 'ply')" : "binary data inside the PLY header");
    const auto words = split_words(line);
    if (line_number == 1) {
      if (words.size() != 1 || words[0] != "ply") fail("not a PLY file (first line must be 'ply')");
      continue;
    }
    if (words.empty()) continue;
    const std::string_view key = words[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "format") {
      if (words.size() < 2) fail("incomplete 'format' line");
      if (words[1] == "ascii") h.encoding = Encoding::Ascii;
      else if (words[1] == "binary_little_endian") h.encoding = Encoding::BinaryLittleEndian;
      else if (words[1] == "binary_big_endian") h.encoding = Encoding::BinaryBigEndian;
      else fail("unknown PLY format '" + std::string(words[1]) + "'");
      have_format = true;
    } else if (key == "element") {
      if (words.size() != 3) fail("'element' needs a name and a count");
      Element e;
      e.name = words[1];
      e.line = line_number;
      if (!parse_integer(words[2], e.count) || e.count < 0) fail("bad element count '" + std::string(words[2]) + "'");
      if (e.count > max_element_count) fail("element count " + std::string(words[2]) + " too large");
      h.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (h.elements.empty()) fail("'property' before any 'element'");
      Property p;
      if (words.size() == 5 && words[1] == "list") {
        const auto count_type = scalar_from_name(words[2]);
        const auto item_type = scalar_from_name(words[3]);
        if (!count_type || !item_type) fail("unknown property type in list property");
        if (is_float(*count_type)) fail("list count type must be an integer type");
        p.is_list = true;
        p.count_type = *count_type;
        p.type = *item_type;
        p.name = words[4];
      } else if (words.size() == 3) {
        const auto type = scalar_from_name(words[1]);
        if (!type) fail("unknown property type '" + std::string(words[1]) + "'");
        p.type = *type;
        p.name = words[2];
      } else {
        fail("malformed 'property' line");
      }
      h.elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      ended = true;
    } else {
      fail("unknown PLY header line '" + std::string(key.substr(0, 40)) + "'");
    }
  }
  if (!have_format) throw InputError(with_file(path, "PLY header has no 'format' line"));
  h.body_offset = pos;
  h.body_line = line_number + 1;
  return h;
}

// Values of the body, binary: bounds-checked at every read.
class BinaryBody {
public:
  BinaryBody(const std::string& path, std::string_view bytes, std::size_t offset, bool big_endian)
      : path_(path), bytes_(bytes), pos_(offset), big_endian_(big_endian) {}

  void set_context(const Element& e, long long item) {
    element_ = &e;
    item_ = item;
  }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  bool at_end() const { return pos_ == bytes_.size(); }

  double read_double(Scalar t) {
    need(scalar_size(t));
    const char* d = bytes_.data() + pos_;
    pos_ += scalar_size(t);
    switch (t) {
    case Scalar::Float32: return load_value<float>(d, big_endian_);
    case Scalar::Float64: return load_value<double>(d, big_endian_);
    default: return static_cast<double>(decode_integer(t, d));
    }
  }
  long long read_integer(Scalar t, const char* what) {
    if (is_float(t)) fail(std::string(what) + " stored as floating point, expected an integer type");
    need(scalar_size(t));
    const char* d = bytes_.data() + pos_;
    pos_ += scalar_size(t);
    return decode_integer(t, d);
  }
  void check_list_fits(long long n, Scalar item) {
    if (n < 0) fail("negative list length " + std::to_string(n));
    if (static_cast<unsigned long long>(n) * scalar_size(item) > remaining())
      fail("list of " + std::to_string(n) + " values runs past the end of the file (truncated or corrupt)");
  }
  [[noreturn]] void fail(const std::string& what) const {
    std::string where;
    if (element_) where = " in element '" + element_->name + "' item " + std::to_string(item_) + " of " +
                          std::to_string(element_->count);
    throw InputError(with_file(path_, what + where));
  }

private:
  void need(int n) {
    if (remaining() < static_cast<std::size_t>(n))
      fail("binary data ends early (truncated file or wrong counts)");
  }
  long long decode_integer(Scalar t, const char* d) const {
    switch (t) {
    case Scalar::Int8: return load_value<std::int8_t>(d, big_endian_);
    case Scalar::UInt8: return load_value<std::uint8_t>(d, big_endian_);
    case Scalar::Int16: return load_value<std::int16_t>(d, big_endian_);
    case Scalar::UInt16: return load_value<std::uint16_t>(d, big_endian_);
    case Scalar::Int32: return load_value<std::int32_t>(d, big_endian_);
    case Scalar::UInt32: return load_value<std::uint32_t>(d, big_endian_);
    default: return 0;
    }
  }

  const std::string& path_;
  std::string_view bytes_;
  std::size_t pos_;
  bool big_endian_;
  const Element* element_ = nullptr;
  long long item_ = 0;
};

// Values of the body, ASCII: one token each; lines are not significant.
class AsciiBody {
public:
  AsciiBody(const std::string& path, std::string_view bytes, std::size_t offset, int line)
      : bytes_(bytes), s_(bytes, path, '\0', offset, line) {}

  void set_context(const Element& e, long long item) {
    element_ = &e;
    item_ = item;
  }
  std::size_t remaining() const { return bytes_.size() - s_.position(); }
  bool at_end() { return s_.at_end(); }

  double read_double(Scalar t) {
    const std::string_view token = next();
    return is_float(t) ? s_.to_double(token, "a number") : static_cast<double>(s_.to_integer(token, "an integer"));
  }
  long long read_integer(Scalar t, const char* what) {
    if (is_float(t)) fail(std::string(what) + " declared as floating point, expected an integer type");
    return s_.to_integer(next(), what);
  }
  void check_list_fits(long long n, Scalar) {
    if (n < 0) fail("negative list length " + std::to_string(n));
    if (static_cast<unsigned long long>(n) > remaining() / 2 + 1)
      fail("list of " + std::to_string(n) + " values is longer than the rest of the file");
  }
  [[noreturn]] void fail(const std::string& what) const { s_.fail(what + where()); }

private:
  std::string where() const {
    return element_ ? " in element '" + element_->name + "' item " + std::to_string(item_) : std::string();
  }
  std::string_view next() {
    const std::string_view token = s_.next_token();
    if (token.empty()) fail("unexpected end of file (truncated or wrong counts)");
    return token;
  }

  std::string_view bytes_;
  TextScanner s_;
  const Element* element_ = nullptr;
  long long item_ = 0;
};

// Smallest number of bytes one item of `e` can take in the file.
long long min_item_bytes(const Element& e, Encoding encoding) {
  long long total = 0;
  for (const Property& p : e.properties)
    total += encoding == Encoding::Ascii ? 2 : scalar_size(p.is_list ? p.count_type : p.type);
  return total;
}

template <class Body>
TriMesh read_body(Body& body, const Header& h, const std::string& path) {
  long long num_vertices = 0;
  bool have_vertices = false;
  for (const Element& e : h.elements)
    if (e.name == "vertex") {
      num_vertices = e.count;
      have_vertices = true;
    }
  SurfaceBuilder b;
  std::vector<int> polygon;
  for (const Element& e : h.elements) {
    const long long min_bytes = min_item_bytes(e, h.encoding);
    if (e.count * min_bytes > static_cast<long long>(body.remaining()) + 1)
      throw InputError(with_file(path, "header claims " + std::to_string(e.count) + " '" + e.name +
                                           "' elements but only " + std::to_string(body.remaining()) +
                                           " bytes of data follow (truncated or wrong counts) (line " +
                                           std::to_string(e.line) + ")"));
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int coordinate_of[3] = {-1, -1, -1}; // property index of x, y, z
    int index_list = -1;
    for (int k = 0; k < static_cast<int>(e.properties.size()); ++k) {
      const Property& p = e.properties[k];
      if (is_vertex && !p.is_list && (p.name == "x" || p.name == "y" || p.name == "z")) coordinate_of[p.name[0] - 'x'] = k;
      if (is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) index_list = k;
    }
    if (is_vertex && (coordinate_of[0] < 0 || coordinate_of[1] < 0 || coordinate_of[2] < 0))
      throw InputError(with_file(path, "element 'vertex' lacks scalar properties x, y and z (line " +
                                           std::to_string(e.line) + ")"));
    if (is_face && index_list < 0)
      throw InputError(with_file(path, "element 'face' has no list property 'vertex_indices' (line " +
                                           std::to_string(e.line) + ")"));
    if (is_face && is_float(e.properties[index_list].type))
      throw InputError(with_file(path, "face vertex indices must have an integer type (line " +
                                           std::to_string(e.line) + ")"));
    if (is_vertex) b.xyz.reserve(static_cast<std::size_t>(3 * e.count));
    if (is_face) b.corners.reserve(static_cast<std::size_t>(3 * e.count));

    if (e.properties.empty()) continue; // nothing stored per item

    for (long long item = 0; item < e.count; ++item) {
      body.set_context(e, item);
      double xyz[3] = {0, 0, 0};
      for (int k = 0; k < static_cast<int>(e.properties.size()); ++k) {
        const Property& p = e.properties[k];
        if (!p.is_list) {
          const double value = body.read_double(p.type);
          for (int c = 0; c < 3; ++c)
            if (coordinate_of[c] == k) xyz[c] = value;
          continue;
        }
        const long long n = body.read_integer(p.count_type, "list length");
        body.check_list_fits(n, p.type);
        if (k == index_list) {
          if (n < 3) body.fail("face with " + std::to_string(n) + " vertices, need at least 3");
          polygon.clear();
          for (long long j = 0; j < n; ++j) {
            const long long id = body.read_integer(p.type, "vertex index");
            if (id < 0 || id >= num_vertices)
              body.fail("vertex index " + std::to_string(id) + " out of range (" + std::to_string(num_vertices) +
                        " vertices)");
            polygon.push_back(static_cast<int>(id));
          }
          SurfaceBuilder::add_fan(b.corners, polygon);
          if (b.corners.size() / 3 >= static_cast<std::size_t>(max_element_count)) body.fail("too many faces");
        } else {
          for (long long j = 0; j < n; ++j) body.read_double(p.type);
        }
      }
      if (is_vertex) b.xyz.insert(b.xyz.end(), xyz, xyz + 3);
    }
  }
  if (!have_vertices) throw InputError(with_file(path, "PLY file has no 'vertex' element"));
  return b.finish();
}

} // namespace

TriMesh read_ply(const std::string& path, std::string_view bytes, std::vector<std::string>* skipped_names) {
  const Header h = parse_header(path, bytes);
  SkippedData skipped(skipped_names);
  for (const Element& e : h.elements) {
    if (e.count == 0) continue;
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    if (!is_vertex && !is_face) {
      skipped.add("'" + e.name + "' elements");
      continue;
    }
    for (const Property& p : e.properties)
      if (!(is_vertex && !p.is_list && (p.name == "x" || p.name == "y" || p.name == "z")) &&
          !(is_face && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")))
        skipped.add(e.name + " property '" + p.name + "'");
  }
  if (h.encoding == Encoding::Ascii) {
    AsciiBody body(path, bytes, h.body_offset, h.body_line);
    TriMesh mesh = read_body(body, h, path);
    if (!body.at_end())
      throw InputError(with_file(path, "data left after the last element the header announced (wrong counts?)"));
    return mesh;
  }
  BinaryBody body(path, bytes, h.body_offset, h.encoding == Encoding::BinaryBigEndian);
  TriMesh mesh = read_body(body, h, path);
  if (!body.at_end())
    throw InputError(with_file(path, std::to_string(body.remaining()) +
                                         " bytes left after the last element the header announced (wrong length or counts)"));
  return mesh;
}

} // namespace gshell::io_detail
