"""Hardware and processor in the loop: the ECU firmware in the emulator
over CAN (:mod:`hpctl.hil.pil`).

Needs the ``hil`` extra (``pip install hpctl[hil]``: python-can, cantools,
crccheck, pyserial) and, to run the firmware, QEMU (``docs/firmware.md``).
"""
