// The viewer's wire format (view/view_protocol.h): every documented message parses to what it
// says, everything else is one InputError (never a crash, never a partial message), and the
// binary frames carry their header and payload as docs/viewer.md describes.
#include <gshell/error.h>
#include <gshell/view/view_protocol.h>

#include <gtest/gtest.h>

#include <cstring>
#include <string>

using namespace gshell;

namespace {

ViewMessageLimits limits(int vertex_count = 100) {
  ViewMessageLimits l;
  l.vertex_count = vertex_count;
  l.max_bytes = 4096;
  l.max_handles = 16;
  return l;
}

ViewMessage parse(const std::string& text, const ViewMessageLimits& l = limits()) { return parse_view_message(text, l); }

/// The InputError's message, or "" when the text parsed.
std::string rejection(const std::string& text, const ViewMessageLimits& l = limits()) {
  try {
    parse_view_message(text, l);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

template <class T>
T as(const ViewMessage& m) {
  EXPECT_TRUE(std::holds_alternative<T>(m)) << view_message_type(m);
  return std::get<T>(m);
}

std::uint32_t u32(const std::string& bytes, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}
float f32(const std::string& bytes, std::size_t at) {
  float v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

} // namespace

TEST(ViewProtocol, EveryMessageParsesToWhatItSays) {
  const ViewAddHandle add = as<ViewAddHandle>(parse(R"({"type":"add_handle","name":"rim","vertices":[0,5,99,5]})"));
  EXPECT_EQ(add.name, "rim");
  EXPECT_EQ(add.vertices, (std::vector<int>{0, 5, 99, 5}));
  EXPECT_EQ(as<ViewAddHandle>(parse(R"({"type":"add_handle","vertices":[3]})")).name, "");
  EXPECT_EQ(as<ViewRemoveHandle>(parse(R"({"type":"remove_handle","handle":15})")).handle, 15);
  const ViewSetHandleVertices set =
      as<ViewSetHandleVertices>(parse(R"({"type":"set_handle_vertices","handle":2,"vertices":[7,8]})"));
  EXPECT_EQ(set.handle, 2);
  EXPECT_EQ(set.vertices, (std::vector<int>{7, 8}));
  EXPECT_EQ(as<ViewGrab>(parse(R"({"type":"grab","handle":1})")).handle, 1);

  const ViewDrag drag = as<ViewDrag>(
      parse(R"({"type":"drag","seq":4294967295,"handle":1,"translate":[0.5,-1e-3,2],"axis":[0,0,2],"degrees":-30})"));
  EXPECT_EQ(drag.seq, 4294967295u);
  EXPECT_EQ(drag.handle, 1);
  EXPECT_EQ(drag.translate, Eigen::Vector3d(0.5, -1e-3, 2));
  EXPECT_EQ(drag.axis, Eigen::Vector3d(0, 0, 2));
  EXPECT_EQ(drag.degrees, -30);
  const ViewDrag plain = as<ViewDrag>(parse(R"({"type":"drag","seq":0,"handle":0,"translate":[1,2,3]})"));
  EXPECT_EQ(plain.degrees, 0); // no rotation unless asked
  EXPECT_EQ(plain.axis, Eigen::Vector3d::UnitZ());

  as<ViewRelease>(parse(R"({"type":"release"})"));
  as<ViewUndo>(parse(R"({"type":"undo"})"));
  as<ViewReset>(parse(R"({"type":"reset"})"));
  as<ViewSaveHandles>(parse(R"({"type":"save_handles"})"));
  as<ViewCertify>(parse(R"({"type":"certify"})"));
  as<ViewDrawn>(parse(R"({"type":"drawn"})"));
  const ViewLoadHandles load = as<ViewLoadHandles>(parse(R"({"type":"load_handles","name":"a.json","text":"{}"})"));
  EXPECT_EQ(load.name, "a.json");
  EXPECT_EQ(load.text, "{}");
  EXPECT_EQ(as<ViewSaveShell>(parse(R"({"type":"save_shell","folder":"bowl-pulled_2.v1"})")).folder, "bowl-pulled_2.v1");
  EXPECT_EQ(as<ViewShowFrame>(parse(R"({"type":"frame","index":12})")).index, 12);
  // Key order and white space do not matter.
  EXPECT_EQ(as<ViewGrab>(parse(" {\n\"handle\" : 3 ,\t\"type\":\"grab\"} ")).handle, 3);
}

TEST(ViewProtocol, MalformedMessagesAreOneClearError) {
  EXPECT_NE(rejection(""), "");
  EXPECT_NE(rejection("{"), "");
  EXPECT_NE(rejection("not json"), "");
  EXPECT_NE(rejection("[1,2]").find("expected a JSON object"), std::string::npos);
  EXPECT_NE(rejection(R"({"handle":1})").find("missing \"type\""), std::string::npos);
  EXPECT_NE(rejection(R"({"type":7})").find("\"type\" must be a string"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"explode"})").find("unknown type"), std::string::npos);
  // Unknown keys are typos, not silently ignored.
  EXPECT_NE(rejection(R"({"type":"grab","handle":1,"hnadle":2})").find("unknown key \"hnadle\""), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"undo","now":true})").find("unknown key"), std::string::npos);
  // A key given twice, of which JSON readers keep one ({"type":"undo","type":"reset"} ran a reset).
  EXPECT_EQ(rejection(R"({"type":"undo","type":"reset"})"), "message: the key \"type\" appears twice in one object");
  EXPECT_NE(rejection(R"({"type":"grab","handle":1,"handle":2})").find("\"handle\" appears twice"), std::string::npos);
  // Missing and mistyped fields.
  EXPECT_NE(rejection(R"({"type":"grab"})").find("missing \"handle\""), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"grab","handle":"1"})").find("must be an integer"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"grab","handle":1.5})").find("must be an integer"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[1,2]})").find("[x, y, z]"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[1,"2",3]})"), "");
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[0,0,0],"degrees":"9"})"), "");
  EXPECT_NE(rejection(R"({"type":"load_handles","text":5})").find("must be a string"), std::string::npos);
  // Invalid UTF-8 inside a string, and a control character in a name.
  EXPECT_NE(rejection("{\"type\":\"add_handle\",\"name\":\"\xff\xfe\",\"vertices\":[1]}"), "");
  EXPECT_NE(rejection(R"({"type":"add_handle","name":"a\u0007b","vertices":[1]})").find("control character"),
            std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","name":")" + std::string(65, 'x') + R"(","vertices":[1]})"), "");
  // Binary garbage.
  EXPECT_NE(rejection(std::string("\0\x01\x02\x03", 4)), "");
}

TEST(ViewProtocol, NumbersAndIdsAreChecked) {
  // JSON has no NaN or infinity; numbers that overflow a double are not finite either.
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[NaN,0,0]})"), "");
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[1e999,0,0]})"), "");
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[0,0,0],"degrees":-1e400})"), "");
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[0,0,0],"axis":[0,0,0]})").find("zero"),
            std::string::npos);
  EXPECT_NE(rejection(R"({"type":"drag","seq":1,"handle":0,"translate":[0,0,0],"axis":[1e308,1e308,0]})"), "");
  // Vertex ids: 0..vertex_count-1, integers only, never wrapped around.
  EXPECT_EQ(rejection(R"({"type":"add_handle","vertices":[0,99]})"), "");
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[100]})").find("out of range 0..99"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[-1]})").find("out of range"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[4294967296]})").find("out of range"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[18446744073709551615]})").find("out of range"),
            std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[1e20]})"), "");
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[2.0]})").find("integer"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[]})").find("empty"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":5})"), "");
  EXPECT_NE(rejection(R"({"type":"remove_handle","handle":16})").find("out of range"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"drag","seq":4294967296,"handle":0,"translate":[0,0,0]})"), "");
  EXPECT_NE(rejection(R"({"type":"drag","seq":-1,"handle":0,"translate":[0,0,0]})"), "");
  EXPECT_NE(rejection(R"({"type":"frame","index":-3})"), "");
  // No shell loaded yet: no vertex id is valid.
  EXPECT_NE(rejection(R"({"type":"add_handle","vertices":[0]})", limits(0)), "");
}

TEST(ViewProtocol, SizeAndDepthAreBounded) {
  const ViewMessageLimits l = limits(1000000);
  std::string big = R"({"type":"add_handle","vertices":[)";
  while (big.size() < l.max_bytes) big += "1,";
  big += "1]}";
  EXPECT_NE(rejection(big, l).find("too long"), std::string::npos);
  // Deep nesting is refused before any parser recursion (8 levels at most).
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  ViewMessageLimits roomy = l;
  roomy.max_bytes = 1u << 20;
  EXPECT_NE(rejection(deep, roomy).find("nested deeper"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"grab","handle":[[[[[[[[1]]]]]]]]})", roomy).find("nested deeper"), std::string::npos);
  // Brackets inside strings are text, not nesting.
  EXPECT_EQ(rejection(R"({"type":"add_handle","name":"[[[[[[[[[[[[","vertices":[1]})", roomy), "");
  EXPECT_EQ(rejection(R"({"type":"load_handles","text":"{\"a\":\"\\\"[[[[[[[[[[[[\"}"})", roomy), "");
}

TEST(ViewProtocol, FolderNamesArePlainNames) {
  for (const char* good : {"a", "bowl-pulled", "Bunny_2.pose", "x.y.z", "0"}) EXPECT_TRUE(is_plain_folder_name(good)) << good;
  for (const char* bad : {"", ".", "..", ".hidden", "-o", "a/b", "../up", "/abs", "a b", "a\\b", "ä", "a\nb", "C:x"})
    EXPECT_FALSE(is_plain_folder_name(bad)) << bad;
  EXPECT_FALSE(is_plain_folder_name(std::string(65, 'a')));
  EXPECT_TRUE(is_plain_folder_name(std::string(64, 'a')));
  EXPECT_NE(rejection(R"({"type":"save_shell","folder":"../x"})").find("plain name"), std::string::npos);
  EXPECT_NE(rejection(R"({"type":"save_shell","folder":"/tmp/x"})").find("plain name"), std::string::npos);
}

// A run of frame requests is answered by its last one; everything else, and a frame request
// followed by anything else, is acted on.
TEST(ViewProtocol, AFrameRequestTheNextOneReplacesIsSkipped) {
  const std::vector<std::string> batch{
      R"({"type":"frame","index":1})", R"({"type":"frame","index":2})", R"({"type":"frame","index":3})",
      R"({"type":"certify"})",         R"({"type":"frame","index":4})", R"({"type":"frame", "index":5})",
      R"({"type":"frame"})", // malformed: answered with its error, so kept, and the 5 before it too
      R"({"type":"save_shell","folder":"frame"})", R"({"type":"frame","index":6})"};
  const std::vector<std::string_view> views(batch.begin(), batch.end());
  const std::vector<bool> act = view_messages_to_act_on(views, limits());
  EXPECT_EQ(act, (std::vector<bool>{false, false, true, true, false, true, true, true, true}));
  EXPECT_TRUE(view_messages_to_act_on({}, limits()).empty());
  EXPECT_EQ(view_messages_to_act_on({batch[0]}, limits()), std::vector<bool>{true});
}

TEST(ViewProtocol, MessagesThatLeaveTheShellAloneAreKnown) {
  for (const char* alone : {R"({"type":"release"})", R"({"type":"save_handles"})", R"({"type":"certify"})",
                            R"({"type":"save_shell","folder":"a"})", R"({"type":"drawn"})",
                            R"({"type":"drag","seq":1})", "not json"})
    EXPECT_TRUE(view_message_leaves_shell_alone(alone, limits())) << alone;
  for (const char* moves :
       {R"({"type":"drag","seq":1,"handle":0,"translate":[0,0,1]})", R"({"type":"grab","handle":0})",
        R"({"type":"undo"})", R"({"type":"reset"})", R"({"type":"add_handle","vertices":[1]})",
        R"({"type":"remove_handle","handle":0})", R"({"type":"set_handle_vertices","handle":0,"vertices":[1]})",
        R"({"type":"load_handles","name":"h.json","text":"{}"})", R"({"type":"frame","index":1})"})
    EXPECT_FALSE(view_message_leaves_shell_alone(moves, limits())) << moves;
}

TEST(ViewProtocol, BinaryFramesCarryHeaderAndPayload) {
  Eigen::MatrixXd X(2, 3);
  X << 1, 2, 3, 4.5, -5, 1e-3;
  const std::string p = encode_view_positions(ViewFrameKind::Positions, 77, 1.5f, 2.25f, X);
  ASSERT_EQ(p.size(), kViewFrameHeaderBytes + 6 * 4);
  EXPECT_EQ(u32(p, 0), static_cast<std::uint32_t>(ViewFrameKind::Positions));
  EXPECT_EQ(u32(p, 4), 77u);
  EXPECT_EQ(f32(p, 8), 1.5f);
  EXPECT_EQ(f32(p, 12), 2.25f);
  // x y z of vertex 0, then of vertex 1 (row-major, as position buffers hold them).
  const float expected[6] = {1, 2, 3, 4.5f, -5, 1e-3f};
  for (int k = 0; k < 6; ++k) EXPECT_EQ(f32(p, kViewFrameHeaderBytes + 4 * k), expected[k]);

  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, 2, 1, 3;
  const std::string f = encode_view_faces(F);
  ASSERT_EQ(f.size(), kViewFrameHeaderBytes + 6 * 4);
  EXPECT_EQ(u32(f, 0), static_cast<std::uint32_t>(ViewFrameKind::Faces));
  for (int k = 0; k < 6; ++k) EXPECT_EQ(u32(f, kViewFrameHeaderBytes + 4 * k), static_cast<std::uint32_t>(F(k / 3, k % 3)));

  Eigen::VectorXd faces(2), vertices(3);
  faces << 0.5, std::nan("");
  vertices << 1, 0.9, 1.1;
  const std::string v = encode_view_values(9, faces, vertices);
  ASSERT_EQ(v.size(), kViewFrameHeaderBytes + 5 * 4);
  EXPECT_EQ(u32(v, 0), static_cast<std::uint32_t>(ViewFrameKind::Values));
  EXPECT_EQ(f32(v, 8), 2.0f); // counts of face and vertex values
  EXPECT_EQ(f32(v, 12), 3.0f);
  EXPECT_EQ(f32(v, kViewFrameHeaderBytes), 0.5f);
  EXPECT_TRUE(std::isnan(f32(v, kViewFrameHeaderBytes + 4)));
  EXPECT_EQ(f32(v, kViewFrameHeaderBytes + 16), 1.1f);
}
