// TmpFile: one file in a fresh directory under /tmp for a test; both go when it does.
#pragma once

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

struct TmpFile {
    // A new directory /tmp/<prefix>XXXXXX; the file `name` in it is made by write().
    TmpFile(const std::string &prefix, const std::string &name)
    {
        std::string tmpl = "/tmp/" + prefix + "XXXXXX";
        std::vector<char> buf(tmpl.begin(), tmpl.end());
        buf.push_back('\0');
        if (!mkdtemp(buf.data())) {
            throw std::runtime_error("mkdtemp " + tmpl + " failed");
        }
        dir = buf.data();
        path = dir + "/" + name;
    }
    ~TmpFile()
    {
        std::remove(path.c_str());
        rmdir(dir.c_str());
    }
    TmpFile(const TmpFile &) = delete;
    TmpFile &operator=(const TmpFile &) = delete;
    // Replaces the file's contents with `text`.
    void write(const std::string &text) const { std::ofstream(path) << text; }

    std::string dir;  // the directory
    std::string path; // dir/name
};
