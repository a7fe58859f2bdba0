// Datalog: the seed's data logging. start() ('R') creates "Data MM-DD-YY HH;MM;SS.txt"
// in the log folder with the seed's header (the number of parameters, then one line per
// parameter: name, default range low and high); row() appends one line of values per
// frame and flushes it; stop() ('S') closes the file. robot.cpp builds the header and
// every row from one column table, so their counts agree by construction.
#pragma once

#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

namespace navkit {

struct LogParam {
    std::string name;
    double lo, hi; // default plot range
};

class Datalog {
public:
    explicit Datalog(std::string dir) : dir_(std::move(dir)) {}
    ~Datalog() { stop(); }
    // "" on success, else why not. `when` names the file.
    std::string start(std::time_t when, const std::vector<LogParam> &params);
    // "" when written (or not recording); else why not: a row whose count differs from
    // the header's is a bug of the caller, refused and said, never written or dropped
    // quietly.
    std::string row(const std::vector<double> &values);
    void stop();
    bool recording() const { return f_ != nullptr; }
    const std::string &path() const { return path_; }

    static std::string file_name(const std::tm &t);
    static std::string header(const std::vector<LogParam> &params);
    static std::string format_row(const std::vector<double> &values);

private:
    std::string dir_, path_;
    std::FILE *f_ = nullptr;
    size_t n_ = 0;
};

} // namespace navkit
