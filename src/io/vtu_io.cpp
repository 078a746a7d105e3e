// VTK XML UnstructuredGrid (.vtu) with all arrays in one raw appended block (UInt64 byte-count
// headers, Float64 values, Int64 connectivity/offsets, UInt8 cell types = VTK_TETRA 10): compact,
// exact, fast to write, and read by ParaView/VTK. Raw rather than base64 because it is 25% smaller
// and needs no encoder; the reader below reads exactly this layout back (tetrahedra only, raw
// appended data, either byte order, UInt32 or UInt64 headers) and refuses anything else clearly.
#include "binary_codec.h"
#include "tet_formats.h"

#include <gshell/error.h>
#include <gshell/io/xml_escape.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace gshell::io_detail {

namespace {

constexpr std::uint8_t vtk_tetra = 10;

std::string xml_unescape(std::string_view s) {
  static const std::pair<std::string_view, char> entities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    bool replaced = false;
    if (s[i] == '&')
      for (const auto& [entity, c] : entities)
        if (s.substr(i, entity.size()) == entity) {
          out += c;
          i += entity.size();
          replaced = true;
          break;
        }
    if (!replaced) out += s[i++];
  }
  return out;
}

} // namespace

void write_vtu(std::ostream& out, const TetMesh& m) {
  const auto n = static_cast<std::uint64_t>(m.X.rows()), k = static_cast<std::uint64_t>(m.T.rows());
  const bool big = std::endian::native == std::endian::big;
  std::string xml;
  std::uint64_t offset = 0;
  auto data_array = [&](const std::string& type, const std::string& name, long components, std::uint64_t bytes) {
    xml += "        <DataArray type=\"" + type + "\"";
    if (!name.empty()) xml += " Name=\"" + xml_escape(name) + "\"";
    xml += " NumberOfComponents=\"" + std::to_string(components) + "\" format=\"appended\" offset=\"" +
           std::to_string(offset) + "\"/>\n";
    offset += 8 + bytes;
  };
  xml += "<?xml version=\"1.0\"?>\n";
  xml += std::string("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"") +
         (big ? "BigEndian" : "LittleEndian") + "\" header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  xml += "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(k) + "\">\n";
  xml += "      <PointData>\n";
  for (const auto& [name, data] : m.point_data) data_array("Float64", name, data.cols(), 8 * n * data.cols());
  xml += "      </PointData>\n      <CellData>\n";
  for (const auto& [name, data] : m.cell_data) data_array("Float64", name, data.cols(), 8 * k * data.cols());
  xml += "      </CellData>\n      <Points>\n";
  data_array("Float64", "Points", 3, 8 * 3 * n);
  xml += "      </Points>\n      <Cells>\n";
  data_array("Int64", "connectivity", 1, 8 * 4 * k);
  data_array("Int64", "offsets", 1, 8 * k);
  data_array("UInt8", "types", 1, k);
  xml += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
  out.write(xml.data(), static_cast<std::streamsize>(xml.size()));

  // Native byte order is declared in the header, so values are copied as they are in memory.
  std::string block;
  auto flush_block = [&] {
    out.write(block.data(), static_cast<std::streamsize>(block.size()));
    block.clear();
  };
  auto put = [&](auto value) {
    char b[sizeof(value)];
    std::memcpy(b, &value, sizeof(value));
    block.append(b, sizeof(value));
    if (block.size() > (1u << 20)) flush_block();
  };
  auto put_matrix = [&](const Eigen::MatrixXd& data) {
    put(static_cast<std::uint64_t>(8 * data.rows() * data.cols()));
    for (Eigen::Index r = 0; r < data.rows(); ++r)
      for (Eigen::Index c = 0; c < data.cols(); ++c) put(data(r, c));
  };
  for (const auto& a : m.point_data) put_matrix(a.second);
  for (const auto& a : m.cell_data) put_matrix(a.second);
  put_matrix(m.X);
  put(static_cast<std::uint64_t>(8 * 4 * k));
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int c = 0; c < 4; ++c) put(static_cast<std::int64_t>(m.T(t, c)));
  put(static_cast<std::uint64_t>(8 * k));
  for (std::uint64_t t = 0; t < k; ++t) put(static_cast<std::int64_t>(4 * (t + 1)));
  put(static_cast<std::uint64_t>(k));
  for (std::uint64_t t = 0; t < k; ++t) put(vtk_tetra);
  flush_block();
  const std::string tail = "\n  </AppendedData>\n</VTKFile>\n";
  out.write(tail.data(), static_cast<std::streamsize>(tail.size()));
}

namespace {

struct Tag {
  std::string name;
  bool closing = false;
  bool self_closing = false;
  std::map<std::string, std::string> attributes;
  std::size_t end = 0; ///< position just past '>'
};

class VtuParser {
public:
  VtuParser(const std::string& path, std::string_view bytes) : path_(path), bytes_(bytes) {}

  [[noreturn]] void fail(const std::string& what) const { throw InputError(with_file(path_, what)); }

  // Next tag from `pos_`, skipping text, comments and processing instructions.
  std::optional<Tag> next_tag() {
    while (true) {
      const std::size_t lt = bytes_.find('<', pos_);
      if (lt == std::string_view::npos) return std::nullopt;
      if (bytes_.substr(lt, 4) == "<!--") {
        pos_ = find_or_fail("-->", lt) + 3;
        continue;
      }
      if (bytes_.substr(lt, 2) == "<?") {
        pos_ = find_or_fail("?>", lt) + 2;
        continue;
      }
      Tag tag;
      std::size_t i = lt + 1;
      if (i < bytes_.size() && bytes_[i] == '/') {
        tag.closing = true;
        ++i;
      }
      const std::size_t name_begin = i;
      while (i < bytes_.size() && (std::isalnum(static_cast<unsigned char>(bytes_[i])) || bytes_[i] == '_')) ++i;
      tag.name = std::string(bytes_.substr(name_begin, i - name_begin));
      if (tag.name.empty()) fail("malformed XML near byte " + std::to_string(lt));
      while (true) {
        while (i < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[i]))) ++i;
        if (i >= bytes_.size()) fail("XML tag <" + tag.name + "> is not closed (truncated?)");
        if (bytes_[i] == '>') {
          ++i;
          break;
        }
        if (bytes_.substr(i, 2) == "/>") {
          tag.self_closing = true;
          i += 2;
          break;
        }
        const std::size_t key_begin = i;
        while (i < bytes_.size() && bytes_[i] != '=' && bytes_[i] != '>' && !std::isspace(static_cast<unsigned char>(bytes_[i])))
          ++i;
        const std::string key(bytes_.substr(key_begin, i - key_begin));
        while (i < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[i]))) ++i;
        if (i >= bytes_.size() || bytes_[i] != '=') fail("malformed attribute '" + key + "' in <" + tag.name + ">");
        ++i;
        while (i < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[i]))) ++i;
        if (i >= bytes_.size() || (bytes_[i] != '"' && bytes_[i] != '\''))
          fail("malformed attribute '" + key + "' in <" + tag.name + ">");
        const char quote = bytes_[i++];
        const std::size_t close = bytes_.find(quote, i);
        if (close == std::string_view::npos) fail("unterminated attribute in <" + tag.name + "> (truncated?)");
        tag.attributes[key] = xml_unescape(bytes_.substr(i, close - i));
        i = close + 1;
      }
      tag.end = i;
      pos_ = i;
      return tag;
    }
  }

  std::size_t position() const { return pos_; }

private:
  std::size_t find_or_fail(std::string_view what, std::size_t from) const {
    const std::size_t at = bytes_.find(what, from);
    if (at == std::string_view::npos) fail("unterminated XML comment or declaration (truncated?)");
    return at;
  }

  const std::string& path_;
  std::string_view bytes_;
  std::size_t pos_ = 0;
};

struct ArrayInfo {
  std::string section; ///< PointData, CellData, Points or Cells
  std::string name, type;
  long long components = 1;
  unsigned long long offset = 0;
};

int type_size(const std::string& t) {
  if (t == "Int8" || t == "UInt8") return 1;
  if (t == "Int16" || t == "UInt16") return 2;
  if (t == "Int32" || t == "UInt32" || t == "Float32") return 4;
  if (t == "Int64" || t == "UInt64" || t == "Float64") return 8;
  return 0;
}

// Decodes `count` values of type T stored with the given byte order at `data` into `out`.
template <class T>
void decode_as(const char* data, std::size_t count, bool big, double* out) {
  for (std::size_t i = 0; i < count; ++i, data += sizeof(T)) out[i] = static_cast<double>(load_value<T>(data, big));
}

using Decoder = void (*)(const char*, std::size_t, bool, double*);

// Chosen once per array and run over many values at a time: comparing the type's name at every
// value took a quarter of reading a shell.vtu.
Decoder decoder(const std::string& t) {
  if (t == "Float64") return decode_as<double>;
  if (t == "Float32") return decode_as<float>;
  if (t == "Int8") return decode_as<std::int8_t>;
  if (t == "UInt8") return decode_as<std::uint8_t>;
  if (t == "Int16") return decode_as<std::int16_t>;
  if (t == "UInt16") return decode_as<std::uint16_t>;
  if (t == "Int32") return decode_as<std::int32_t>;
  if (t == "UInt32") return decode_as<std::uint32_t>;
  if (t == "Int64") return decode_as<std::int64_t>;
  return decode_as<std::uint64_t>;
}

// An array's values in the file: `tuples` tuples of `components` values each, row-major.
struct Values {
  const char* data;
  std::size_t size; ///< bytes per value
  Decoder decode;
  bool big_endian;
  long long tuples, components;

  /// f(t, v) for the values v of every tuple t, in order, decoded a block at a time (into a small
  /// buffer: decoding a whole array first would touch twice the memory).
  template <class F>
  void for_each_tuple(F&& f) const {
    constexpr long long block = 4096;
    std::vector<double> buffer(static_cast<std::size_t>(std::min(tuples, block) * components));
    for (long long t0 = 0; t0 < tuples; t0 += block) {
      const long long t1 = std::min(tuples, t0 + block);
      decode(data + static_cast<std::size_t>(t0 * components) * size, static_cast<std::size_t>((t1 - t0) * components),
             big_endian, buffer.data());
      for (long long t = t0; t < t1; ++t) f(t, buffer.data() + (t - t0) * components);
    }
  }
  /// All values, a row per tuple.
  Eigen::MatrixXd matrix() const {
    Eigen::MatrixXd values(tuples, components);
    if (components == 1) // one column: the file's order is the matrix's
      decode(data, static_cast<std::size_t>(tuples), big_endian, values.data());
    else
      for_each_tuple([&](long long t, const double* v) {
        for (long long c = 0; c < components; ++c) values(t, c) = v[c];
      });
    return values;
  }
};

long long to_count(const VtuParser& p, const Tag& tag, const std::string& key) {
  const auto it = tag.attributes.find(key);
  if (it == tag.attributes.end()) p.fail("<" + tag.name + "> lacks " + key);
  std::size_t used = 0;
  long long v = -1;
  try {
    v = std::stoll(it->second, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != it->second.size() || v < 0) p.fail("bad " + key + " '" + it->second + "'");
  return v;
}

} // namespace

TetMesh read_vtu(const std::string& path, std::string_view bytes) {
  VtuParser p(path, bytes);
  std::vector<ArrayInfo> arrays;
  std::string section;
  long long num_points = -1, num_cells = -1;
  bool big = false, header64 = false, saw_file = false;
  std::size_t data_start = std::string_view::npos;
  while (auto tag = p.next_tag()) {
    const auto attr = [&](const std::string& key) {
      const auto it = tag->attributes.find(key);
      return it == tag->attributes.end() ? std::string() : it->second;
    };
    if (tag->closing) {
      if (tag->name == section) section.clear();
      continue;
    }
    if (tag->name == "VTKFile") {
      saw_file = true;
      if (attr("type") != "UnstructuredGrid") p.fail("not a VTK UnstructuredGrid file (type '" + attr("type") + "')");
      const std::string order = attr("byte_order");
      if (order != "LittleEndian" && order != "BigEndian") p.fail("unknown byte_order '" + order + "'");
      big = order == "BigEndian";
      const std::string header = attr("header_type");
      if (header != "" && header != "UInt32" && header != "UInt64") p.fail("unknown header_type '" + header + "'");
      header64 = header == "UInt64";
      if (!attr("compressor").empty()) p.fail("compressed .vtu files are not supported");
    } else if (tag->name == "Piece") {
      if (num_points >= 0) p.fail("more than one Piece is not supported");
      num_points = to_count(p, *tag, "NumberOfPoints");
      num_cells = to_count(p, *tag, "NumberOfCells");
    } else if (tag->name == "PointData" || tag->name == "CellData" || tag->name == "Points" || tag->name == "Cells") {
      if (!tag->self_closing) section = tag->name;
    } else if (tag->name == "DataArray") {
      if (section.empty()) p.fail("DataArray outside PointData, CellData, Points or Cells");
      if (attr("format") != "appended")
        p.fail("DataArray '" + attr("Name") + "' has format '" + attr("format") + "', only raw appended data is supported");
      ArrayInfo a;
      a.section = section;
      a.name = attr("Name");
      a.type = attr("type");
      if (type_size(a.type) == 0) p.fail("DataArray '" + a.name + "' has unsupported type '" + a.type + "'");
      a.components = attr("NumberOfComponents").empty() ? 1 : to_count(p, *tag, "NumberOfComponents");
      if (a.components < 1 || a.components > 9) p.fail("DataArray '" + a.name + "' has a bad NumberOfComponents");
      a.offset = static_cast<unsigned long long>(to_count(p, *tag, "offset"));
      arrays.push_back(std::move(a));
    } else if (tag->name == "AppendedData") {
      if (attr("encoding") != "raw") p.fail("AppendedData encoding '" + attr("encoding") + "' is not supported (raw only)");
      const std::size_t underscore = bytes.find('_', tag->end);
      if (underscore == std::string_view::npos) p.fail("AppendedData has no '_' marker (truncated?)");
      data_start = underscore + 1;
      break; // binary data follows; nothing after it matters
    }
  }
  if (!saw_file) p.fail("not a VTK XML file (no <VTKFile>)");
  if (num_points < 0) p.fail("no <Piece> in the file");
  if (data_start == std::string_view::npos) p.fail("no <AppendedData> (truncated?)");

  const std::size_t header_bytes = header64 ? 8 : 4;
  // An array's values, checked to fit the file.
  auto locate = [&](const ArrayInfo& a, long long tuples) {
    const std::size_t size = static_cast<std::size_t>(type_size(a.type));
    if (static_cast<unsigned long long>(tuples) > bytes.size())
      p.fail("DataArray '" + a.name + "' claims more values than the file holds (truncated or wrong counts)");
    if (a.offset > bytes.size() || data_start + a.offset + header_bytes > bytes.size())
      p.fail("DataArray '" + a.name + "' starts past the end of the file (truncated?)");
    const char* block = bytes.data() + data_start + a.offset;
    const unsigned long long declared = header64 ? load_value<std::uint64_t>(block, big) : load_value<std::uint32_t>(block, big);
    const unsigned long long expected = static_cast<unsigned long long>(tuples) * a.components * size;
    if (declared != expected)
      p.fail("DataArray '" + a.name + "' holds " + std::to_string(declared) + " bytes, expected " + std::to_string(expected));
    if (data_start + a.offset + header_bytes + expected > bytes.size())
      p.fail("DataArray '" + a.name + "' runs past the end of the file (truncated?)");
    return Values{block + header_bytes, size, decoder(a.type), big, tuples, a.components};
  };
  auto read_array = [&](const ArrayInfo& a, long long tuples) { return locate(a, tuples).matrix(); };
  auto find = [&](const std::string& sec, const std::string& name) -> const ArrayInfo* {
    for (const ArrayInfo& a : arrays)
      if (a.section == sec && (name.empty() || a.name == name)) return &a;
    return nullptr;
  };

  TetMesh mesh;
  const ArrayInfo* points = find("Points", "");
  if (!points || points->components != 3) p.fail("no 3-component Points array");
  mesh.X = read_array(*points, num_points);
  const ArrayInfo* connectivity = find("Cells", "connectivity");
  const ArrayInfo* offsets = find("Cells", "offsets");
  const ArrayInfo* types = find("Cells", "types");
  if (!connectivity || !offsets || !types) p.fail("Cells lacks connectivity, offsets or types");
  locate(*types, num_cells).for_each_tuple([&](long long c, const double* type) {
    if (*type != vtk_tetra) p.fail("cell " + std::to_string(c) + " is not a tetrahedron (only tets are supported)");
  });
  locate(*offsets, num_cells).for_each_tuple([&](long long c, const double* offset) {
    if (*offset != 4.0 * (c + 1)) p.fail("cell offsets are not those of tetrahedra");
  });
  mesh.T.resize(num_cells, 4);
  locate(*connectivity, 4 * num_cells).for_each_tuple([&](long long i, const double* first) {
    const double id = *first;
    // Ids arrive as doubles (any array type is decoded to double): a whole number in range,
    // tested before the conversion to int (converting 1e19 or NaN is undefined behaviour).
    const long long c = i / 4;
    if (!(id >= 0 && id < static_cast<double>(num_points) && id == std::floor(id))) {
      char text[32];
      std::snprintf(text, sizeof text, "%.17g", id);
      p.fail("cell " + std::to_string(c) + " refers to point " + text + ", not a point id (the file has " +
             std::to_string(num_points) + " points)");
    }
    mesh.T(c, i % 4) = static_cast<int>(id);
  });
  for (const ArrayInfo& a : arrays) {
    if (a.section == "PointData") mesh.point_data.emplace_back(a.name, read_array(a, num_points));
    if (a.section == "CellData") mesh.cell_data.emplace_back(a.name, read_array(a, num_cells));
  }
  return mesh;
}

} // namespace gshell::io_detail
