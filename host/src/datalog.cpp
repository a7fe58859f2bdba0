#include "navkit/datalog.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <unistd.h>

namespace navkit {

std::string Datalog::file_name(const std::tm &t)
{
    char b[64];
    std::strftime(b, sizeof b, "Data %m-%d-%y %H;%M;%S.txt", &t);
    return b;
}

std::string Datalog::header(const std::vector<LogParam> &params)
{
    std::string h = std::to_string(params.size()) + "\n";
    char b[160];
    for (const LogParam &p : params) {
        std::snprintf(b, sizeof b, "%s %g %g\n", p.name.c_str(), p.lo, p.hi);
        h += b;
    }
    return h;
}

std::string Datalog::format_row(const std::vector<double> &values)
{
    std::string r;
    char b[40];
    for (size_t i = 0; i < values.size(); i++) {
        std::snprintf(b, sizeof b, i ? "\t%.10g" : "%.10g", values[i]);
        r += b;
    }
    return r + "\n";
}

std::string Datalog::start(std::time_t when, const std::vector<LogParam> &params)
{
    stop();
    std::tm t;
    localtime_r(&when, &t);
    const std::string name = file_name(t);
    // two recordings in one second: "Data ... (2).txt", never overwrite a log
    for (int k = 1; k < 100; k++) {
        std::string p = dir_ + "/" + name;
        if (k > 1) {
            p = p.substr(0, p.size() - 4) + " (" + std::to_string(k) + ").txt";
        }
        const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd < 0 && errno == EEXIST) {
            continue;
        }
        if (fd < 0) {
            return p + ": " + std::strerror(errno);
        }
        f_ = fdopen(fd, "w");
        path_ = p;
        break;
    }
    if (!f_) {
        return dir_ + "/" + name + ": exists";
    }
    n_ = params.size();
    std::fputs(header(params).c_str(), f_);
    std::fflush(f_);
    return "";
}

std::string Datalog::row(const std::vector<double> &values)
{
    if (!f_) {
        return "";
    }
    if (values.size() != n_) {
        return path_ + ": a row of " + std::to_string(values.size()) + " values for " + std::to_string(n_) +
               " columns: not written";
    }
    std::fputs(format_row(values).c_str(), f_);
    std::fflush(f_); // a crash loses at most this row
    return "";
}

void Datalog::stop()
{
    if (f_) {
        std::fclose(f_);
        f_ = nullptr;
    }
}

} // namespace navkit
