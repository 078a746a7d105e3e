#pragma once
// Numbered frames, the one naming rule for sequences: `gshell animate` writes frame_0001.obj ..,
// `gshell deform` writes frame_0001/ .. (a shell folder each). Numbers have at least four digits,
// and every name of a sequence as many as its largest number (frame_00001 .. frame_12000), so
// that sorting the names as text (a shell's glob) orders the frames too.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace gshell {

/// "frame_0007" + extension (e.g. ".obj", or "" for a folder); with the digits of `count` (the
/// sequence's frame count) where it has more than four. 0 <= k <= count where count is given.
std::string frame_name(int k, const std::string& extension = {}, int count = 0);

/// The number of a frame name with this extension: "frame_" and 1 to 9 digits, as frame_name
/// makes them or with fewer digits ("frame_0012.obj", "frame_12.obj" -> 12; `extension` in lower
/// case matches the name's in any case: "frame_0012.OBJ"), or nothing when the name is not one.
std::optional<int> frame_number(const std::string& name, const std::string& extension = {});

/// The frames in `dir`, ordered by number (frame_9999 before frame_10000): folders when
/// `extension` is empty, files with that extension otherwise. Empty when `dir` is not a folder.
/// \throws InputError naming `dir` when two names have one number (frame_2.obj, frame_0002.obj).
std::vector<std::filesystem::path> list_frames(const std::filesystem::path& dir, const std::string& extension = {});

/// Base frames named on a command line: a file as it is; a folder as its frame files in order
/// (frame_NNNN.obj, or .off, .ply, .stl where it holds no .obj ones), so that `gshell deform --base
/// DIR` takes what `gshell animate -o DIR` wrote.
/// \throws InputError naming a folder that holds no frame files (a shell folder: naming its base.obj).
std::vector<std::string> expand_frame_arguments(const std::vector<std::string>& arguments);

} // namespace gshell
