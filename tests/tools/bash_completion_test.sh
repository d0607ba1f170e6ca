#!/bin/bash
# The bash completion (tools/completion/modtap) under Debian's bash-completion, as bash calls it
# on TAB: the options and their choices are those modtap's --help prints (computed here from
# --help too, so the test follows the program), model names are `modtap models`' names, and the
# values that are files, folders and ports complete as such.
# Usage: bash_completion_test.sh MODTAP [COMPLETION_SCRIPT]
# Skipped (77) without the bash-completion package.
set -uo pipefail
fail() { echo "FAIL: $*"; exit 1; }
modtap=$(realpath "$1") || fail "no modtap at $1"
script=$(realpath "${2:-$(dirname "$0")/../../tools/completion/modtap}") || fail "no completion script"
# The completion runs `modtap` as typed on the line: this build's.
PATH=$(dirname "$modtap"):$PATH
[ "$(command -v modtap)" = "$modtap" ] || fail "the binary must be named modtap to be found on PATH"

[ -f /usr/share/bash-completion/bash_completion ] ||
  { echo "SKIP: no bash-completion package (/usr/share/bash-completion/bash_completion)"; exit 77; }
# shellcheck source=/dev/null
source /usr/share/bash-completion/bash_completion || fail "sourcing bash-completion"
# shellcheck source=/dev/null
source "$script" || fail "sourcing $script"
complete -p modtap | grep -q -- '-F _modtap' || fail "$script does not register _modtap for modtap"

# Files to complete, and nothing else in the working folder.
work=$(mktemp -d) || fail "mktemp"
trap 'rm -rf "$work"' EXIT
cd "$work" || fail "cd $work"
mkdir my-models && touch capture.pcapng ttyFAKE

# COMPREPLY, sorted one a line, for LINE with the cursor at its end. The words are split as bash
# splits them: at blanks, with each '=' a word of its own (COMP_WORDBREAKS).
complete_line() {
  COMP_LINE=$1 COMP_POINT=${#1}
  read -ra COMP_WORDS <<<"${1//=/ = }"
  [[ $1 == *' ' ]] && COMP_WORDS+=('')
  COMP_CWORD=$((${#COMP_WORDS[@]} - 1)) COMPREPLY=()
  # compopt complains outside a real completion; that is not the completion's failure.
  _modtap modtap "${COMP_WORDS[COMP_CWORD]}" "${COMP_WORDS[COMP_CWORD - 1]}" 2>/dev/null
  ((${#COMPREPLY[@]})) && printf '%s\n' "${COMPREPLY[@]}" | sort -u
}
lines() { printf '%s\n' "$@" | sort -u; }
# expect LINE WANTED...: the completion offers exactly WANTED.
expect() {
  local line=$1 got want
  shift
  got=$(complete_line "$line") want=$( (($#)) && lines "$@")
  [ "$got" = "$want" ] || fail "'$line<TAB>' offers [${got//$'\n'/ }], expected [${want//$'\n'/ }]"
}
# offers LINE VALUE...: the completion offers at least each VALUE.
offers() {
  local line=$1 got v
  shift
  got=$(complete_line "$line")
  for v; do
    grep -qxF -- "$v" <<<"$got" || fail "'$line<TAB>' offers [${got//$'\n'/ }], without $v"
  done
}

help=$(modtap --help) || fail "modtap --help"
# The long options, the first --name on each option line of --help.
mapfile -t long < <(sed -n 's/^  \(-[^-, ]*,\)\{0,1\}\(--[a-z0-9-]*\).*/\2/p' <<<"$help")
((${#long[@]} > 30)) || fail "read only ${#long[@]} long options from --help"
expect "modtap --" "${long[@]}"
expect "modtap --for" --format
expect "modtap --models" --models-dir
offers "modtap -" --read --interface -t -c

# Every option --help gives choices ({a,b,c}) completes to exactly those; --baud (BAUD|auto)
# to auto and the usual rates.
choice_lines=$(grep -E '^  -[^ ]* \{' <<<"$help")
[ "$(wc -l <<<"$choice_lines")" -ge 8 ] || fail "found too few options with choices in --help"
while read -r opts type _; do
  choices=${type#*\{} choices=${choices%%\}*}
  IFS=, read -ra choices <<<"$choices"
  for name in ${opts//,/ }; do expect "modtap $name " "${choices[@]}"; done
done <<<"$choice_lines"
grep -qE '^  --baud BAUD\|auto ' <<<"$help" || fail "--help does not say --baud takes BAUD or auto"
offers "modtap --baud " auto 9600 19200 115200
offers "modtap --format " pcapng
expect "modtap --format pcap" pcap pcapng
expect "modtap --format=pcap" pcap pcapng
expect "modtap -T j" json
expect "modtap --output=c" csv
expect "modtap --parity e" even

# Model names, for the bus or one slave.
mapfile -t names < <(modtap models | awk '{ print $1 }')
printf '%s\n' "${names[@]}" | grep -qx nta5000 || fail "modtap models does not list nta5000"
expect "modtap --model " "${names[@]}"
expect "modtap --model 3=" "${names[@]}"
expect "modtap --model 3=nta5000" nta5000 nta5000-cn
expect "modtap --models-dir my-models --model gd" gd20

# Subcommands on the first word, and theirs after them.
expect "modtap mo" models
offers "modtap " fields models capture.pcapng
expect "modtap models " check
expect "modtap models check cap" capture.pcapng
expect "modtap fields "

# Files, folders and ports.
expect "modtap -r cap" capture.pcapng
expect "modtap --read=cap" capture.pcapng
expect "modtap cap" capture.pcapng
expect "modtap -w cap" capture.pcapng
expect "modtap --report cap" capture.pcapng
expect "modtap --models-dir " my-models
expect "modtap -i ma" master=
offers "modtap --interface " master= slave=
expect "modtap -i slave=./tty" ./ttyFAKE
if [ -e /dev/ttyS0 ]; then
  offers "modtap -i /dev/ttyS" /dev/ttyS0
  offers "modtap -i master=/dev/ttyS" /dev/ttyS0
fi

# A value only the user knows: nothing, neither files nor options.
expect "modtap -Y "
expect "modtap --follow "
expect "modtap --mqtt-interval "

echo "bash completes modtap: ${#long[@]} long options and the choices from --help," \
     "${#names[@]} models, subcommands, files, folders, ports"
