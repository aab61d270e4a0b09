#!/usr/bin/env python3
"""A copy of an x86-64 binary that valgrind 3.19 can run, for counting
instructions with callgrind (BENCHMARKS.md, "Semi-active 8x8: the last 5 %").

valgrind 3.19 stops with SIGILL on the register form of VEX `vmovq`
(`C5 x9 D6 /r`, mod = 11), which the compiler puts into hp-vehicle's AVX2
drive loop. Each is rewritten as the `vmovaps` of the same length
(`C5 x8 29 /r`): the same low lane, the upper lane copied instead of zeroed,
so the same instruction count as long as the upper lane is not read. Check
that by the output: the drive_8x8 checksum under valgrind must be the
unpatched binary's. For measuring only; never run the copy for results.

    scripts/callgrind_vmovq.py target/release/examples/drive_8x8 /tmp/drive_8x8_vg
"""

import re
import subprocess
import sys


def main(src: str, dst: str) -> None:
    data = bytearray(open(src, "rb").read())
    # Virtual address -> file offset, from the section headers.
    sections = []
    for line in subprocess.run(["objdump", "-h", src], capture_output=True, text=True, check=True).stdout.splitlines():
        f = line.split()
        if len(f) >= 7 and f[0].isdigit():
            sections.append((int(f[3], 16), int(f[2], 16), int(f[5], 16)))

    def offset(va: int) -> int:
        for vma, size, file_offset in sections:
            if vma <= va < vma + size:
                return va - vma + file_offset
        raise ValueError(hex(va))

    count = 0
    listing = subprocess.run(["objdump", "-d", src], capture_output=True, text=True, check=True).stdout
    for line in listing.splitlines():
        m = re.match(r"\s+([0-9a-f]+):\s+c5 ([0-9a-f]9) d6 ([0-9a-f]{2})\s+vmovq\s+%xmm\d+,%xmm\d+", line)
        if not m:
            continue
        o, vex, modrm = offset(int(m.group(1), 16)), int(m.group(2), 16), int(m.group(3), 16)
        assert modrm >> 6 == 3 and data[o] == 0xC5 and data[o + 1] == vex and data[o + 2] == 0xD6
        data[o + 1] = vex & ~0x01  # pp = 00: no 66 prefix (vmovaps)
        data[o + 2] = 0x29
        count += 1
    open(dst, "wb").write(data)
    print(f"{count} vmovq rewritten: {dst}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
