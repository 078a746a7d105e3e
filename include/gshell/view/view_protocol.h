#pragma once
// The wire format of `gshell view` (docs/viewer.md): what a page may send (JSON text messages,
// parsed and validated by one pure function) and the binary frames the server sends back
// (a 16-byte header, then float32 or uint32 arrays, little endian).
//
// Every message a page sends goes through parse_view_message before anything acts on it: that
// function is the whole attack surface of the server's WebSocket (a fuzz target), so it accepts
// only the documented shapes, checks every number, id and length against ViewMessageLimits and
// throws InputError with a one-line reason for anything else.
#include <gshell/error.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace gshell {

/// What parse_view_message accepts.
struct ViewMessageLimits {
  /// Largest message in bytes. 16 MiB holds the explicit ids of ~2 million vertices.
  std::size_t max_bytes = 16u << 20;
  /// Shell vertex ids must lie in 0..vertex_count-1 (2n for a shell of n base vertices).
  int vertex_count = 0;
  /// Handle group indices must lie in 0..max_handles-1 (the session checks the actual count).
  int max_handles = 1024;
};

/// Longest handle or folder name.
constexpr std::size_t kViewNameLength = 64;
/// Deepest nesting of arrays and objects a message may have (the deepest valid one has 3).
constexpr int kViewMessageDepth = 8;

// ---- page -> server (JSON text; "type" names the message) -----------------------------------

/// {"type":"add_handle","name":S,"vertices":[ids]}: a new named group of shell vertices.
struct ViewAddHandle {
  std::string name;
  std::vector<int> vertices; ///< non-empty, each in 0..vertex_count-1 (duplicates allowed)
};
/// {"type":"remove_handle","handle":K}
struct ViewRemoveHandle {
  int handle = 0;
};
/// {"type":"set_handle_vertices","handle":K,"vertices":[ids]}: group K gets this vertex set.
struct ViewSetHandleVertices {
  int handle = 0;
  std::vector<int> vertices;
};
/// {"type":"grab","handle":K}: a drag of group K begins (an undo point).
struct ViewGrab {
  int handle = 0;
};
/// {"type":"drag","seq":N,"handle":K,"translate":[x,y,z],"axis":[x,y,z],"degrees":D}: group K's
/// rigid motion from rest (rotate by D degrees about `axis` through the group's rest centroid,
/// then translate; in page units, i.e. model units times hello's "unit"). `seq` (0..2^32-1) comes
/// back in the positions frame that answers it. `axis` and `degrees` may be left out (no rotation).
struct ViewDrag {
  std::uint32_t seq = 0;
  int handle = 0;
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ(); ///< not zero
  double degrees = 0;
};
/// {"type":"release"}: the mouse button is up; settle without waiting for the mouse to rest.
struct ViewRelease {};
/// {"type":"undo"}
struct ViewUndo {};
/// {"type":"reset"}: the shell back at rest, every motion cleared (groups kept).
struct ViewReset {};
/// {"type":"save_handles"}: the server answers with the handle file (docs/handles.md).
struct ViewSaveHandles {};
/// {"type":"load_handles","name":S,"text":S}: a handle file's content (S = its name, for messages).
struct ViewLoadHandles {
  std::string name;
  std::string text;
};
/// {"type":"save_shell","folder":S}: write the posed shell as `gshell pose` does into a new
/// folder S of the server's output folder. S is a plain name ([A-Za-z0-9][A-Za-z0-9._-]*), never
/// a path.
struct ViewSaveShell {
  std::string folder;
};
/// {"type":"frame","index":K}: show frame K of a sequence.
struct ViewShowFrame {
  int index = 0;
};
/// {"type":"certify"}: compute the validity figures (inverted tets, intersections) now.
struct ViewCertify {};
/// {"type":"drawn"}: the page has drawn the last positions frame it got (flow control: a page that
/// sends these gets at most one positions frame it has not drawn yet; the server's network thread
/// handles them, the session never sees them).
struct ViewDrawn {};

using ViewMessage = std::variant<ViewAddHandle, ViewRemoveHandle, ViewSetHandleVertices, ViewGrab, ViewDrag,
                                 ViewRelease, ViewUndo, ViewReset, ViewSaveHandles, ViewLoadHandles, ViewSaveShell,
                                 ViewShowFrame, ViewCertify, ViewDrawn>;

/// The "type" of a message, as on the wire.
const char* view_message_type(const ViewMessage& message);

/// Parses and validates one text message from a page.
/// \throws InputError with a one-line reason: too long, too deeply nested, not UTF-8 JSON, not an
///         object, unknown "type" or key, a missing or mistyped field, a non-finite number, an id
///         or index out of range, an empty vertex list, a zero rotation axis, a bad name.
ViewMessage parse_view_message(std::string_view bytes, const ViewMessageLimits& limits);

/// Whether `bytes` parses as a message of type T (ViewDrawn, ViewShowFrame, ...); false when it
/// does not parse (the session answers it with the parser's error).
template <class T>
bool is_view_message(std::string_view bytes, const ViewMessageLimits& limits) {
  try {
    return std::holds_alternative<T>(parse_view_message(bytes, limits));
  } catch (const InputError&) {
    return false;
  }
}

/// Which of a batch of page messages (in the order they came) to act on: every one but a "frame"
/// request directly followed by another, whose frame the next one would replace at once. A slider
/// dragged over a sequence asks for every frame it passes; where frames are read when shown (about
/// a fifth of a second each for 1.3M shell vertices) answering them all lags seconds behind the
/// slider. Messages that do not parse are kept (they are answered with their error).
std::vector<bool> view_messages_to_act_on(const std::vector<std::string_view>& batch, const ViewMessageLimits& limits);

/// Whether answering `bytes` leaves the shell and its targets as they are: a release (settle now),
/// a handle file asked for, a save (refused while the shell moves), a certificate asked for, a
/// "drawn", or a message that does not parse (answered with its error). A viewer answers these while a settle runs
/// instead of interrupting it: a guarded settle that is interrupted starts again from its last
/// valid state, so pages asking such things every few seconds kept the shell from ever settling.
bool view_message_leaves_shell_alone(std::string_view bytes, const ViewMessageLimits& limits);

/// A folder name a page may ask the server to write: 1..64 characters of [A-Za-z0-9._-], not
/// starting with '.' or '-' (so never "..", a hidden file, an option or a path).
bool is_plain_folder_name(std::string_view name);

// ---- server -> page: binary frames -----------------------------------------------------------

/// Binary frames: a 16-byte header {uint32 kind, uint32 seq, float32 a, float32 b}, then the
/// payload, all little endian. The header keeps the payload 4-byte aligned for typed arrays.
enum class ViewFrameKind : std::uint32_t {
  Faces = 1,     ///< payload uint32[3m]: the base faces (the top has the same); seq 0
  Positions = 2, ///< payload float32[2n*3]: base rows then top rows; seq = last drag answered,
                 ///< a = solve milliseconds, b = milliseconds from the drag's arrival to this frame
  Values = 3,    ///< payload float32[m + n]: per-face stretch, then per-vertex thickness/eta
  Frame = 4,     ///< as Positions, for sequence frame seq (a, b = 0)
};
constexpr std::size_t kViewFrameHeaderBytes = 16;

/// A Positions or Frame frame of the 2n x 3 shell vertices in page units, (x - origin) * unit (the
/// session's, `hello`'s "origin" and "unit"), rounded to float32. A float has 24 bits: positions
/// sent as they are from a scan in survey coordinates (millions of units from zero) would be drawn
/// on a grid of 0.25-0.5 units; relative to the shell's centre they keep their detail. `unit`
/// (a power of two, 1 for shells of ordinary size) keeps a shell beyond the float range
/// (3.4e38) or below its normal range drawable.
/// \throws InputError when X does not have 3 columns.
std::string encode_view_positions(ViewFrameKind kind, std::uint32_t seq, float a, float b, const Eigen::MatrixXd& X,
                                  const Eigen::RowVector3d& origin = Eigen::RowVector3d::Zero(), double unit = 1);
/// A Values frame: per-face values (m), then per-vertex values (n), rounded to float32.
std::string encode_view_values(std::uint32_t seq, const Eigen::VectorXd& face_values,
                               const Eigen::VectorXd& vertex_values);
/// The Faces frame.
std::string encode_view_faces(const Eigen::MatrixXi& F);

} // namespace gshell
