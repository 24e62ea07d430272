#!/bin/sh
# Run a libsail test program built for Cortex-M4F on QEMU's mps2-an386 (a Cortex-M4 with an FPU):
#   run.sh PROGRAM.elf [ARG...]
# The arguments reach main() through the semihosting command line; stdout, files and the exit
# status go through semihosting too.  A run longer than SAIL_QEMU_TIMEOUT seconds (default 60)
# is killed and fails (exit 124).
set -eu
exe=$1
shift
escape() { printf '%s' "$1" | sed 's/,/,,/g'; }  # QEMU's option syntax doubles a literal comma
config="enable=on,target=native,arg=$(escape "$(basename "$exe")")"
for a in "$@"; do
    config="$config,arg=$(escape "$a")"
done
exec timeout "${SAIL_QEMU_TIMEOUT:-60}" qemu-system-arm -M mps2-an386 -nographic -monitor none -serial none \
    -semihosting-config "$config" ${SAIL_QEMU_FLAGS:-} -kernel "$exe"
