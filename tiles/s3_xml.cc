#include "tiles/s3_xml.h"

#include <expat.h>

#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <vector>

namespace zoomwarp::tiles {

bool parse_xml(std::string_view xml, const std::function<void(const std::string& path, std::string& text)>& on_end) {
  struct State {
    std::vector<std::size_t> lengths;  // path length before each open element
    std::string path;
    std::vector<std::string> texts;
    const std::function<void(const std::string&, std::string&)>* on_end;
    XML_Parser parser;
  } st;
  st.on_end = &on_end;
  const std::unique_ptr<std::remove_pointer_t<XML_Parser>, decltype(&XML_ParserFree)> parser(
      XML_ParserCreate("UTF-8"), &XML_ParserFree);
  if (!parser) throw std::bad_alloc();
  st.parser = parser.get();
  XML_SetUserData(parser.get(), &st);
  XML_SetElementHandler(
      parser.get(),
      [](void* p, const XML_Char* name, const XML_Char**) {
        auto* s = static_cast<State*>(p);
        s->lengths.push_back(s->path.size());
        if (!s->path.empty()) s->path += '/';
        s->path += name;
        s->texts.emplace_back();
      },
      [](void* p, const XML_Char*) {
        auto* s = static_cast<State*>(p);
        (*s->on_end)(s->path, s->texts.back());
        s->texts.pop_back();
        s->path.resize(s->lengths.back());
        s->lengths.pop_back();
      });
  XML_SetCharacterDataHandler(parser.get(), [](void* p, const XML_Char* data, int len) {
    auto* s = static_cast<State*>(p);
    if (!s->texts.empty()) s->texts.back().append(data, std::size_t(len));
  });
  XML_SetStartDoctypeDeclHandler(parser.get(), [](void* p, const XML_Char*, const XML_Char*, const XML_Char*, int) {
    XML_StopParser(static_cast<State*>(p)->parser, XML_FALSE);
  });
  if (xml.size() > std::size_t(INT32_MAX)) return false;
  return XML_Parse(parser.get(), xml.data(), int(xml.size()), XML_TRUE) == XML_STATUS_OK;
}

}  // namespace zoomwarp::tiles
