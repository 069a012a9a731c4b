#include "hal/can/dbc.hpp"

#include <fstream>
#include <sstream>

namespace zonemap::can {
namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

// SG_ name : start|len@order sign (factor,offset) [min|max] "unit" receivers
bool parse_signal(const std::string& text, DbcSignal* s) {
  std::istringstream in(text);
  std::string tag, colon, layout, scaling, range;
  if (!(in >> tag >> s->name >> colon) || tag != "SG_" || colon != ":") return false;
  if (!(in >> layout >> scaling >> range)) return false;
  int start = 0, length = 0;
  char bar = 0, at = 0, order = 0, sign = 0;
  std::istringstream l(layout);
  if (!(l >> start >> bar >> length >> at >> order >> sign) || bar != '|' || at != '@') {
    return false;
  }
  if ((order != '0' && order != '1') || (sign != '+' && sign != '-')) return false;
  s->start_bit = start;
  s->length = length;
  s->little_endian = order == '1';
  s->is_signed = sign == '-';
  char open = 0, comma = 0, close = 0;
  std::istringstream sc(scaling);
  if (!(sc >> open >> s->factor >> comma >> s->offset >> close) || open != '(' || comma != ',' ||
      close != ')') {
    return false;
  }
  std::istringstream rg(range);
  if (!(rg >> open >> s->minimum >> bar >> s->maximum >> close) || open != '[' || bar != '|' ||
      close != ']') {
    return false;
  }
  const auto q1 = text.find('"');
  const auto q2 = q1 == std::string::npos ? q1 : text.find('"', q1 + 1);
  if (q2 == std::string::npos) return false;
  s->unit = text.substr(q1 + 1, q2 - q1 - 1);
  return true;
}

}  // namespace

bool read_dbc(const std::string& path, std::vector<DbcMessage>* messages, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open";
    return false;
  }
  std::string raw;
  int line = 0;
  while (std::getline(in, raw)) {
    ++line;
    const std::string text = trim(raw);
    const auto fail = [&](const char* what) {
      *error = path + ":" + std::to_string(line) + ": " + what;
      return false;
    };
    if (text.rfind("BO_ ", 0) == 0) {
      std::istringstream l(text);
      std::string tag, name, sender;
      std::uint64_t id = 0;
      int dlc = 0;
      if (!(l >> tag >> id >> name >> dlc) || name.empty() || name.back() != ':') {
        return fail("BO_ <id> <name>: <dlc> <sender> expected");
      }
      DbcMessage m;
      m.extended = (id & 0x80000000u) != 0;
      m.id = static_cast<std::uint32_t>(id & 0x1FFFFFFFu);
      m.name = name.substr(0, name.size() - 1);
      m.dlc = dlc;
      messages->push_back(m);
    } else if (text.rfind("SG_ ", 0) == 0) {
      if (messages->empty()) return fail("SG_ before any BO_");
      DbcSignal s;
      if (!parse_signal(text, &s)) return fail("cannot read this SG_ line");
      messages->back().signals.push_back(s);
    }
  }
  return true;
}

}  // namespace zonemap::can

#include <cmath>
#include <iomanip>

namespace zonemap::can {

void write_dbc(std::ostream& out, std::string_view comment, std::string_view sender,
               std::span<const MessageSpec> messages) {
  out << "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: INS ZONEMAP FC\n\n";
  out << std::setprecision(12);
  for (const MessageSpec& m : messages) {
    const std::uint64_t id = m.id | (m.extended ? 0x80000000u : 0u);
    out << "BO_ " << id << " " << m.name << ": " << int{m.dlc} << " " << sender << "\n";
    for (const SignalSpec& s : m.signals) {
      const double lo_raw = s.is_signed ? -std::ldexp(1.0, s.length - 1) : 0.0;
      const double hi_raw =
          s.is_signed ? std::ldexp(1.0, s.length - 1) - 1.0 : std::ldexp(1.0, s.length) - 1.0;
      out << " SG_ " << s.name << " : " << s.start_bit << "|" << s.length << "@"
          << (s.little_endian ? 1 : 0) << (s.is_signed ? "-" : "+") << " (" << s.factor << ","
          << s.offset << ") [" << lo_raw * s.factor + s.offset << "|"
          << hi_raw * s.factor + s.offset << "] \"" << s.unit << "\" "
          << (sender == "ZONEMAP" ? "FC" : "ZONEMAP") << "\n";
    }
    out << "\n";
  }
  out << "CM_ \"" << comment << "\";\n";
}

}  // namespace zonemap::can
