#include <gshell/view/view_protocol.h>

#include "io/json_input.h"

#include <gshell/error.h>

#include <nlohmann/json.hpp>

#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <set>

namespace gshell {

static_assert(std::endian::native == std::endian::little, "the wire format is little endian");

using nlohmann::json;

namespace {

[[noreturn]] void fail(const std::string& type, const std::string& problem) {
  throw InputError(type.empty() ? "message: " + problem : "message \"" + type + "\": " + problem);
}

// A value shown in a message: short, whatever the page sent.
std::string shown(const json& value) {
  std::string text = value.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

class Fields {
public:
  Fields(const json& object, std::string type, std::set<std::string> allowed)
      : object_(object), type_(std::move(type)) {
    allowed.insert("type");
    for (const auto& [key, value] : object.items())
      if (!allowed.count(key)) {
        std::string list;
        for (const auto& a : allowed)
          if (a != "type") list += (list.empty() ? "" : ", ") + a;
        fail(type_, "unknown key \"" + (key.size() > 40 ? key.substr(0, 37) + "..." : key) + "\"" +
                        (list.empty() ? " (it takes none)" : " (expected " + list + ")"));
      }
  }

  bool has(const char* key) const { return object_.contains(key); }

  const json& at(const char* key) const {
    const auto it = object_.find(key);
    if (it == object_.end()) fail(type_, std::string("missing \"") + key + "\"");
    return *it;
  }

  double number(const char* key) const {
    const json& v = at(key);
    if (!v.is_number()) fail(type_, std::string("\"") + key + "\" must be a number, got " + shown(v));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(type_, std::string("\"") + key + "\" is not finite");
    return x;
  }

  // An integer in [0, end).
  std::int64_t index(const json& v, const std::string& what, std::int64_t end) const {
    std::int64_t i = -1;
    if (v.is_number_unsigned()) {
      const std::uint64_t u = v.get<std::uint64_t>();
      i = u < static_cast<std::uint64_t>(end) ? static_cast<std::int64_t>(u) : end;
    } else if (v.is_number_integer()) {
      i = v.get<std::int64_t>();
    } else {
      fail(type_, what + " must be an integer, got " + shown(v));
    }
    if (i < 0 || i >= end)
      fail(type_, what + " " + shown(v) + " is out of range 0.." + std::to_string(end - 1));
    return i;
  }

  int handle(std::int64_t max_handles) const {
    return static_cast<int>(index(at("handle"), "handle", max_handles));
  }

  std::vector<int> vertices(int vertex_count) const {
    const json& v = at("vertices");
    if (!v.is_array()) fail(type_, "\"vertices\" must be an array of shell vertex ids");
    if (v.empty()) fail(type_, "\"vertices\" is empty");
    std::vector<int> ids;
    ids.reserve(v.size());
    for (const json& id : v) ids.push_back(static_cast<int>(index(id, "vertex id", vertex_count)));
    return ids;
  }

  Eigen::Vector3d vector3(const char* key) const {
    const json& v = at(key);
    if (!v.is_array() || v.size() != 3) fail(type_, std::string("\"") + key + "\" must be [x, y, z], got " + shown(v));
    Eigen::Vector3d out;
    for (int k = 0; k < 3; ++k) {
      if (!v[k].is_number()) fail(type_, std::string("\"") + key + "\" must hold numbers, got " + shown(v));
      out[k] = v[k].get<double>();
      if (!std::isfinite(out[k])) fail(type_, std::string("\"") + key + "\" is not finite");
    }
    return out;
  }

  std::string text(const char* key, std::size_t max_length) const {
    const json& v = at(key);
    if (!v.is_string()) fail(type_, std::string("\"") + key + "\" must be a string, got " + shown(v));
    std::string s = v.get<std::string>();
    if (s.size() > max_length) fail(type_, std::string("\"") + key + "\" is longer than " + std::to_string(max_length));
    return s;
  }

  // A label: printable, no control characters (it is shown on pages and written to files).
  std::string name(const char* key) const {
    std::string s = text(key, kViewNameLength);
    for (const unsigned char c : s)
      if (c < 0x20 || c == 0x7f) fail(type_, std::string("\"") + key + "\" holds a control character");
    return s;
  }

private:
  const json& object_;
  std::string type_;
};

using Parser = std::function<ViewMessage(const json&, const ViewMessageLimits&)>;

const std::map<std::string, Parser>& parsers() {
  static const std::map<std::string, Parser> table{
      {"add_handle",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         const Fields f(o, "add_handle", {"name", "vertices"});
         return ViewAddHandle{f.has("name") ? f.name("name") : std::string(), f.vertices(l.vertex_count)};
       }},
      {"remove_handle",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         return ViewRemoveHandle{Fields(o, "remove_handle", {"handle"}).handle(l.max_handles)};
       }},
      {"set_handle_vertices",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         const Fields f(o, "set_handle_vertices", {"handle", "vertices"});
         return ViewSetHandleVertices{f.handle(l.max_handles), f.vertices(l.vertex_count)};
       }},
      {"grab",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         return ViewGrab{Fields(o, "grab", {"handle"}).handle(l.max_handles)};
       }},
      {"drag",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         const Fields f(o, "drag", {"seq", "handle", "translate", "axis", "degrees"});
         ViewDrag d;
         d.seq = static_cast<std::uint32_t>(f.index(f.at("seq"), "seq", std::int64_t(1) << 32));
         d.handle = f.handle(l.max_handles);
         d.translate = f.vector3("translate");
         if (f.has("axis")) d.axis = f.vector3("axis");
         if (f.has("degrees")) d.degrees = f.number("degrees");
         if (!(d.axis.norm() > 0)) fail("drag", "\"axis\" is zero");
         if (!std::isfinite(d.axis.norm())) fail("drag", "\"axis\" is too long");
         return d;
       }},
      {"release", [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "release", {}); return ViewRelease{}; }},
      {"undo", [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "undo", {}); return ViewUndo{}; }},
      {"reset", [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "reset", {}); return ViewReset{}; }},
      {"save_handles",
       [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "save_handles", {}); return ViewSaveHandles{}; }},
      {"load_handles",
       [](const json& o, const ViewMessageLimits& l) -> ViewMessage {
         const Fields f(o, "load_handles", {"name", "text"});
         return ViewLoadHandles{f.has("name") ? f.name("name") : std::string("handles"), f.text("text", l.max_bytes)};
       }},
      {"save_shell",
       [](const json& o, const ViewMessageLimits&) -> ViewMessage {
         const Fields f(o, "save_shell", {"folder"});
         std::string folder = f.text("folder", kViewNameLength);
         if (!is_plain_folder_name(folder))
           fail("save_shell", "\"folder\" must be a plain name of letters, digits, '.', '_' and '-' (not starting "
                              "with '.' or '-'), got " + shown(json(folder)));
         return ViewSaveShell{std::move(folder)};
       }},
      {"frame",
       [](const json& o, const ViewMessageLimits&) -> ViewMessage {
         const Fields f(o, "frame", {"index"});
         return ViewShowFrame{static_cast<int>(f.index(f.at("index"), "index", std::int64_t(1) << 30))};
       }},
      {"certify", [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "certify", {}); return ViewCertify{}; }},
      {"drawn", [](const json& o, const ViewMessageLimits&) -> ViewMessage { Fields(o, "drawn", {}); return ViewDrawn{}; }},
  };
  return table;
}

} // namespace

const char* view_message_type(const ViewMessage& message) {
  static constexpr const char* names[] = {"add_handle", "remove_handle", "set_handle_vertices", "grab",
                                          "drag",       "release",       "undo",                "reset",
                                          "save_handles", "load_handles", "save_shell",         "frame",
                                          "certify",    "drawn"};
  static_assert(std::size(names) == std::variant_size_v<ViewMessage>);
  return names[message.index()];
}

std::vector<bool> view_messages_to_act_on(const std::vector<std::string_view>& batch, const ViewMessageLimits& limits) {
  const auto is_frame_request = [&](std::string_view bytes) { // no second parse of other messages
    return bytes.find("\"frame\"") != std::string_view::npos && is_view_message<ViewShowFrame>(bytes, limits);
  };
  std::vector<bool> frame(batch.size()), act(batch.size(), true);
  for (std::size_t k = 0; k < batch.size(); ++k) frame[k] = is_frame_request(batch[k]);
  for (std::size_t k = 0; k + 1 < batch.size(); ++k) act[k] = !(frame[k] && frame[k + 1]);
  return act;
}

bool view_message_leaves_shell_alone(std::string_view bytes, const ViewMessageLimits& limits) {
  try {
    const ViewMessage m = parse_view_message(bytes, limits);
    return std::holds_alternative<ViewRelease>(m) || std::holds_alternative<ViewSaveHandles>(m) || std::holds_alternative<ViewSaveShell>(m) ||
           std::holds_alternative<ViewCertify>(m) || std::holds_alternative<ViewDrawn>(m);
  } catch (const InputError&) {
    return true;
  }
}

bool is_plain_folder_name(std::string_view name) {
  if (name.empty() || name.size() > kViewNameLength || name.front() == '.' || name.front() == '-') return false;
  for (const char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
          c == '-'))
      return false;
  return true;
}

ViewMessage parse_view_message(std::string_view bytes, const ViewMessageLimits& limits) {
  if (bytes.size() > limits.max_bytes)
    fail("", "too long (" + std::to_string(bytes.size()) + " bytes, at most " + std::to_string(limits.max_bytes) + ")");
  // Checked before parsing, so that nothing recursive ever walks a deep tree from a page.
  if (io_detail::json_nesting_depth(bytes, kViewMessageDepth) > kViewMessageDepth)
    fail("", "nested deeper than " + std::to_string(kViewMessageDepth) + " levels");
  json message;
  std::string repeated; // {"type":"undo","type":"reset"} ran a reset: refused, as in handle files
  try {
    message = io_detail::parse_json_noting_repeated_keys(bytes, repeated);
  } catch (const json::exception& e) { // parse errors, and numbers that overflow (out_of_range)
    fail("", io_detail::not_valid_json(e));
  }
  if (!repeated.empty()) fail("", "the key \"" + repeated + "\" appears twice in one object");
  if (!message.is_object()) fail("", "expected a JSON object");
  const auto type = message.find("type");
  if (type == message.end()) fail("", "missing \"type\"");
  if (!type->is_string()) fail("", "\"type\" must be a string");
  const auto parser = parsers().find(type->get<std::string>());
  if (parser == parsers().end()) {
    std::string list;
    for (const auto& [name, p] : parsers()) list += (list.empty() ? "" : ", ") + name;
    fail("", "unknown type " + shown(*type) + " (expected one of " + list + ")");
  }
  return parser->second(message, limits);
}

namespace {

std::string frame_header(ViewFrameKind kind, std::uint32_t seq, float a, float b, std::size_t payload_bytes) {
  std::string out(kViewFrameHeaderBytes + payload_bytes, '\0');
  const std::uint32_t k = static_cast<std::uint32_t>(kind);
  std::memcpy(out.data(), &k, 4);
  std::memcpy(out.data() + 4, &seq, 4);
  std::memcpy(out.data() + 8, &a, 4);
  std::memcpy(out.data() + 12, &b, 4);
  return out;
}

void put_floats(char* out, const double* values, Eigen::Index count) {
  for (Eigen::Index i = 0; i < count; ++i) {
    const float f = static_cast<float>(values[i]);
    std::memcpy(out + 4 * i, &f, 4);
  }
}

} // namespace

std::string encode_view_positions(ViewFrameKind kind, std::uint32_t seq, float a, float b, const Eigen::MatrixXd& X,
                                  const Eigen::RowVector3d& origin, double unit) {
  if (X.cols() != 3) throw InputError("encode_view_positions: X must have 3 columns");
  std::string out = frame_header(kind, seq, a, b, 4 * static_cast<std::size_t>(X.size()));
  // Row-major x y z per vertex, as WebGL position buffers hold them.
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rows = (X.rowwise() - origin) * unit;
  put_floats(out.data() + kViewFrameHeaderBytes, rows.data(), rows.size());
  return out;
}

std::string encode_view_values(std::uint32_t seq, const Eigen::VectorXd& face_values, const Eigen::VectorXd& vertex_values) {
  std::string out = frame_header(ViewFrameKind::Values, seq, static_cast<float>(face_values.size()),
                                 static_cast<float>(vertex_values.size()),
                                 4 * static_cast<std::size_t>(face_values.size() + vertex_values.size()));
  put_floats(out.data() + kViewFrameHeaderBytes, face_values.data(), face_values.size());
  put_floats(out.data() + kViewFrameHeaderBytes + 4 * face_values.size(), vertex_values.data(), vertex_values.size());
  return out;
}

std::string encode_view_faces(const Eigen::MatrixXi& F) {
  std::string out = frame_header(ViewFrameKind::Faces, 0, 0, 0, 4 * static_cast<std::size_t>(F.size()));
  char* p = out.data() + kViewFrameHeaderBytes;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < F.cols(); ++k) {
      const std::uint32_t v = static_cast<std::uint32_t>(F(f, k));
      std::memcpy(p, &v, 4);
      p += 4;
    }
  return out;
}

} // namespace gshell
