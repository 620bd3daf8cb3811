# Sourced by the fetch-*.sh scripts (which define `die`): sets the array `pip` to a pip that
# works (python3 -m pip, python -m pip, pip3 or pip) and checks python3, which unpacks wheels.
pip=()
for py in python3 python; do
  if command -v "$py" >/dev/null 2>&1 && "$py" -m pip --version >/dev/null 2>&1; then pip=("$py" -m pip); break; fi
done
if [ ${#pip[@]} -eq 0 ]; then
  for p in pip3 pip; do
    if command -v "$p" >/dev/null 2>&1; then pip=("$p"); break; fi
  done
fi
[ ${#pip[@]} -gt 0 ] || die "pip was not found; install it (sudo apt-get install python3-pip) and run this again"
command -v python3 >/dev/null 2>&1 || die "python3 was not found (needed to unpack the wheel); sudo apt-get install python3"
