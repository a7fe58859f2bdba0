"""Helpers of the simulated-board tests (test_simboard, test_flash; no tests here): test
images for the ATmega2560 built with the real avr-gcc, the plain avrdude command of the
Mega's bootloader, and the board's pace."""

import subprocess
from pathlib import Path

__all__ = ["TEST_SPEED", "ECHO_C", "build_image", "avrdude"]

TEST_SPEED = 4.0    # simulated s per wall s: the bootloader waits ~0.25 s of wall time

# The image-info block (firmware/avr/board_info.h; little-endian) as C: version 1 (36 bytes)
# or, with {link}, version 2 (37: + the link byte); {hash} {sig} {mcu} {version} filled in.
INFO_C = r"""
#include <avr/pgmspace.h>
#include <stdint.h>
struct image_info { char magic[8]; uint8_t version; uint8_t signature[3]; uint32_t spec_hash;
                    uint32_t f_cpu_hz; char mcu[16]; {link_field} };
const struct image_info image_info __attribute__((used)) PROGMEM =
    { {'N','A','V','K','I','T','I','M'}, {version}, {{{sig}}}, {hash}UL, 16000000UL, "{mcu}" {link} };
"""

# Greets at boot, then sends back each byte + 1: shows when the image runs and its UART.
ECHO_C = r"""
#include <avr/io.h>
static void tx(uint8_t c) { while (!(UCSR0A & (1 << UDRE0))) {} UDR0 = c; }
int main(void)
{
    const char *s = "navkit-test\n";
    UCSR0A = 1 << U2X0; UBRR0 = 16; UCSR0B = (1 << RXEN0) | (1 << TXEN0);  /* 115200 8N1 */
    while (*s) { tx((uint8_t)*s++); }
    for (;;) { if (UCSR0A & (1 << RXC0)) { tx((uint8_t)(UDR0 + 1)); } }
}
"""


def build_image(tmp: Path, name: str, source: str, *, info: dict | None = None) -> Path:
    """Compile `source` for the ATmega2560 with avr-gcc into tmp/name.hex; with `info`
    (keys spec_hash, signature (3 ints), mcu; with key link (its code) a version-2 block,
    else version 1) an image-info block is linked in."""
    if info is not None:
        sig = ", ".join(f"0x{b:02x}" for b in info["signature"])
        v2 = "link" in info
        source += (INFO_C.replace("{{{sig}}}", "{" + sig + "}").replace("{hash}", str(info["spec_hash"]))
                   .replace("{mcu}", info["mcu"]).replace("{version}", "2" if v2 else "1")
                   .replace("{link_field}", "uint8_t link;" if v2 else "")
                   .replace("{link}", f", {info['link']}" if v2 else ""))
    c = tmp / f"{name}.c"
    c.write_text(source)
    elf, hexfile = tmp / f"{name}.elf", tmp / f"{name}.hex"
    subprocess.run(["avr-gcc", "-mmcu=atmega2560", "-Os", "-o", str(elf), str(c)], check=True)
    subprocess.run(["avr-objcopy", "-O", "ihex", "-R", ".eeprom", str(elf), str(hexfile)], check=True)
    return hexfile


def avrdude(port, image: Path, *extra: str) -> subprocess.CompletedProcess:
    """The plain avrdude command of the Mega's bootloader (verification on)."""
    return subprocess.run(["avrdude", "-c", "wiring", "-p", "atmega2560", "-P", str(port),
                           "-b", "115200", *extra, "-U", f"flash:w:{image}:i"],
                          capture_output=True, text=True, timeout=120)
