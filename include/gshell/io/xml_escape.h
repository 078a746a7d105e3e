#pragma once
// Text in XML files (VTU data array names) and in the XHTML/SVG of the report.
#include <string>

namespace gshell {

/// `text` with & < > " ' written as the entities &amp; &lt; &gt; &quot; &apos; (valid in XML
/// text and attribute values, and in HTML5).
std::string xml_escape(const std::string& text);

} // namespace gshell
