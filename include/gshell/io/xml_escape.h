#pragma once
// Text in XML files (VTU data array names) and in the XHTML/SVG of the report.
#include <string>

namespace gshell {

/// `text` with & < > " ' written as the entities &amp; &lt; &gt; &quot; &apos; (valid in XML
/// text and attribute values, and in HTML5). Bytes that are not UTF-8 (a Latin-1 file name) become
/// U+FFFD, as do control characters other than tab and line breaks: an XML file must be UTF-8
/// without them, and ParaView and browsers refuse or garble one that is not.
std::string xml_escape(const std::string& text);

} // namespace gshell
