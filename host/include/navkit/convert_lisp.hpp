// navkit-host --convert-lisp: Navigation::convert as a filter, for tools that must know
// what the host makes of a planner command before a run (tools/navkit/sim/mission.py
// refuses, at mission load, a command the host would drop). docs/host.md.
#pragma once

#include <istream>
#include <ostream>
#include <string>

namespace navkit {

// Reads one JSON object a line from in: lisp_cmd fields by spec name with integer raw
// values (unset fields 0), and optionally "heading", the micro's current heading (deg x
// 0.1, 0..3599; absent: none known, so a heading hold is refused). Writes one JSON object
// a line to out, flushed per line:
//   {"nav_result": "ok" | "not_implemented", "micro_cmd": {every micro_cmd field: raw value}}
//   {"nav_result": "rejected", "refusal": REASON, "lisp_field": NAME, "value": V,
//    ["micro_field": NAME,] ["min": A, "max": B,] "text": "V is outside ..."}
// REASON: lisp_range (outside lisp_cmd's own spec: ProcessCommands refuses it before
// navigation; min..max lisp_field's range), code, range (min..max the range of
// micro_field, the micro_cmd field the value is copied to), heading_range,
// heading_missing (Refusal, navigation.hpp); text is Conversion::text() (the console's
// wording). micro_cmd's dio_command and mc_datalog_cmd are the arbitration's, not the
// conversion's: 0 here.
// Returns 0 at the end of in; on a line that is no such object, 1 with *error =
// "stdin:LINE: byte N: reason" (the lines before it answered).
int convert_lisp_lines(std::istream &in, std::ostream &out, std::string *error);

} // namespace navkit
