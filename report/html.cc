#include "report/html.h"

#include <filesystem>

#include "io/atomic_file.h"
#include "io/png.h"

namespace rigfit {

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string ReportIndexHtml(const std::string& title, const std::string& summary,
                            const std::vector<ReportPicture>& pictures,
                            const std::string& view3d_file) {
  std::string page =
      "<!DOCTYPE html>\n"
      "<html lang=\"en\">\n"
      "<head>\n"
      "<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "<title>" +
      HtmlEscape(title) +
      "</title>\n"
      "<style>\n"
      "body { font-family: sans-serif; margin: 1.5em; color: #111; background: #fff; }\n"
      "pre { font-size: 13px; background: #f4f4f4; padding: 1em; overflow-x: auto; }\n"
      "figure { margin: 1.5em 0; }\n"
      "img { max-width: 100%; height: auto; border: 1px solid #ddd; }\n"
      "figcaption { color: #555; margin-top: 0.3em; }\n"
      "</style>\n"
      "</head>\n"
      "<body>\n"
      "<h1>" +
      HtmlEscape(title) + "</h1>\n";
  if (!summary.empty()) {
    page += "<h2>Summary</h2>\n<pre>" + HtmlEscape(summary) + "</pre>\n";
  }
  if (!view3d_file.empty()) {
    page += "<h2>3-D view</h2>\n<p><a href=\"" + HtmlEscape(view3d_file) +
            "\">Open the interactive 3-D view</a> (" + HtmlEscape(view3d_file) +
            ": orbit, zoom, switch poses and colours; works offline)</p>\n";
  }
  if (!pictures.empty()) page += "<h2>Pictures</h2>\n";
  for (const ReportPicture& p : pictures) {
    page += "<figure>\n<a href=\"" + HtmlEscape(p.file) + "\"><img src=\"" + HtmlEscape(p.file) +
            "\" width=\"" + std::to_string(p.width) + "\" height=\"" + std::to_string(p.height) +
            "\" alt=\"" + HtmlEscape(p.caption) + "\"></a>\n<figcaption>" + HtmlEscape(p.caption) +
            " (" + HtmlEscape(p.file) + ")</figcaption>\n</figure>\n";
  }
  page += "</body>\n</html>\n";
  return page;
}

std::string WriteReportIndex(const std::string& dir, const std::string& title,
                             const std::string& summary, const std::vector<ReportPicture>& pictures,
                             const std::string& view3d_file) {
  const std::string path = (std::filesystem::path(dir) / kReportIndexFile).string();
  WriteTextFileAtomically(path, ReportIndexHtml(title, summary, pictures, view3d_file));
  return path;
}

void ReportDirectory::AddPicture(const char* name, const Image& image, const std::string& caption) {
  files_.push_back((std::filesystem::path(dir_) / name).string());
  WritePng(files_.back(), image);
  pictures_.push_back({name, caption, image.width, image.height});
}

void ReportDirectory::AddView3d(const View3dScene& scene) {
  for (std::string& file : WriteView3d(dir_, scene)) files_.push_back(std::move(file));
  view3d_ = true;
}

std::vector<std::string> ReportDirectory::Finish(const std::string& title,
                                                 const std::string& summary) {
  files_.push_back(WriteReportIndex(dir_, title, summary, pictures_, view3d_ ? kView3dFile : ""));
  return files_;
}

}  // namespace rigfit
