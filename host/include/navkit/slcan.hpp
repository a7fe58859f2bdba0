// Slcan: the host's side of SLCAN, the ASCII protocol of common USB-CAN adapters (Lawicel
// CANUSB, CANable with slcan firmware, USBtin), carried by the micro link's serial port
// when [micro] link = slcan (docs/can.md). Pure text codec: no I/O.
//
// The host writes commands ending in CR ("C", "Sn" bit rate, "O" open, "tIIILDD.." a
// standard frame); the adapter answers CR (done), "z" CR / "Z" CR (frame queued) or BEL
// (refused), and sends each frame it receives as "tIIILDD.." CR ("T" extended, "r"/"R"
// remote; an adapter with time stamps on appends 4 hex digits, ignored here).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace navkit {

// A received frame: 11- or 29-bit identifier, remote and extended flags, dlc data bytes.
struct SlcanFrame {
    uint32_t id = 0;
    bool extended = false;
    bool remote = false;
    uint8_t dlc = 0;
    uint8_t data[8] = {};
};

class Slcan {
public:
    // The SLCAN bit rate command of bit/s `bitrate` ("S6" for 500000), "" if SLCAN has none.
    static std::string bitrate_command(int bitrate);
    // The bit rates SLCAN can set, bit/s, ascending.
    static const std::vector<int> &bitrates();
    // What the host writes after opening the port: close (a channel left open), the bit
    // rate, open; "" if the bit rate is not an SLCAN one.
    static std::string open_commands(int bitrate);
    // The command sending a standard data frame: 11-bit id, 8 data bytes.
    static std::string frame_command(uint16_t id, const uint8_t data[8]);

    // Bytes from the adapter (any chunking): every whole frame line goes to out.
    void feed(const uint8_t *buf, size_t len, std::vector<SlcanFrame> *out);
    // Drop a partial line (the port was reopened).
    void reset() { line_.clear(); }

    uint64_t refused() const { return refused_; }     // BEL answers: a command refused
    uint64_t bad_lines() const { return bad_lines_; } // lines that are no frame and no answer

private:
    bool parse(const std::string &line, SlcanFrame *f) const;
    std::string line_;
    uint64_t refused_ = 0;
    uint64_t bad_lines_ = 0;
};

} // namespace navkit
