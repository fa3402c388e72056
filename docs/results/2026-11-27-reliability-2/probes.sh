#!/usr/bin/env bash
# Issue 43's probe classes against a joca binary, as a careless or hostile user would try them.
# Each probe prints its exit status and joca's first error line, then checks what must hold
# (the user's files unchanged, nothing read outside the folder, no panic). Usage:
#   probes.sh JOCA_BINARY   (from the repository root; writes only under a fresh /tmp folder)
set -uo pipefail
joca="$(realpath "$1")"
weights="$PWD/weights/detector.safetensors"
work="$(mktemp -d /tmp/joca-probes.XXXXXX)"
cd "$work"
fails=0
probe() { # probe NAME EXPECT_SUBSTRING -- joca args…
  local name="$1" expect="$2"; shift 3
  local out rc
  out="$(timeout 300 "$joca" "$@" 2>&1)"; rc=$?
  local line; line="$(grep -m1 -E '^error|panicked' <<<"$out" || true)"
  if grep -q "panicked" <<<"$out"; then verdict="PANIC"; fails=$((fails+1));
  elif [[ -n "$expect" ]] && ! grep -qF -- "$expect" <<<"$out"; then verdict="UNEXPECTED"; fails=$((fails+1));
  else verdict="ok"; fi
  printf '%-52s rc=%-3s %-10s %s\n' "$name" "$rc" "$verdict" "${line:0:160}"
}
same() { # same NAME DIR SNAPSHOT
  if [[ "$(cd "$2" && find . -type f -exec sha256sum {} + | sort)" == "$3" ]]; then
    printf '%-52s %s\n' "  $1: folder unchanged" "ok"
  else printf '%-52s %s\n' "  $1: folder CHANGED" "FAIL"; fails=$((fails+1)); fi
}
snap() { (cd "$1" && find . -type f -exec sha256sum {} + | sort); }

mkdir mine && for f in annotations.json config.toml report.md results.csv notes.txt; do echo "my $f" > "mine/$f"; done
before="$(snap mine)"
printf '[run]\nthreads = 1\ngenerations = 40\npopulation = 2\nsteps_per_candidate = 3\ntest_episodes = 1\ntest_frames_per_episode = 2\n' > long.toml
printf 'title = "t"\nlabel_header = "M"\nscenarios = ["calibrated"]\n[[variant]]\nid = "a"\nlabel = "A"\nrun = { method = "joca" }\n' > exp.toml
mkdir -p kitti/img && : > kitti/0000.txt

echo "## user data: a folder of the user's, holding file names joca writes"
probe "render --out USER_FOLDER" "is not a joca render output" -- render --frames 1 --out mine
probe "import kitti --out USER_FOLDER" "is not a joca import output" -- import kitti --labels kitti/0000.txt --images kitti/img --out mine
probe "experiment --out USER_FOLDER" "is not a joca experiment output" -- experiment exp.toml --config long.toml --out mine
probe "run --out USER_FOLDER (foreign config.toml)" "is not a joca run output" -- run --config long.toml --out mine
probe "blur FRAMES --out USER_FOLDER" "is not a joca blur output" -- blur kitti/img --exposure-ms 5 --out mine
probe "report USER_FOLDER" "no .joca-output marker" -- report mine
same "user folder" mine "$before"
echo data > afile
probe "render --out A_FILE" "is not a folder" -- render --frames 1 --out afile
[[ "$(cat afile)" == data && ! -e .afile.old ]] && echo "  file kept, no .afile.old: ok" || { echo "  file: FAIL"; fails=$((fails+1)); }

echo "## two writers, one run directory"
"$joca" run --config long.toml --out two >/dev/null 2>&1 & first=$!
for _ in $(seq 1200); do [[ -s two/.joca-lock ]] && break; sleep 0.1; done
probe "second joca run, same --out" "being written by another joca process" -- run --config long.toml --out two
probe "joca run --resume while the first runs" "being written by another joca process" -- run --config long.toml --out two --resume
probe "joca eval while the run runs" "being written by another joca process" -- eval two
kill -9 "$first"; wait "$first" 2>/dev/null
probe "after kill -9 of the holder: --resume" "" -- run --config long.toml --out two --resume
grep -q "being written" <<<"$(timeout 5 "$joca" eval two 2>&1)" && { echo "  lock survived the kill: FAIL"; fails=$((fails+1)); } || echo "  lock freed by the kill: ok"

echo "## sandbox: detect --images"
mkdir det
for name in ../../../../etc/passwd /etc/passwd; do
  printf '{"images": [{"id": 1, "file_name": "%s"}]}' "$name" > det/list.json
  probe "detect --images file_name=$name" "is not a path inside" -- detect --weights "$weights" --images det/list.json --out det/dt.json
done
ln -s /etc det/etc; printf '{"images": [{"id": 1, "file_name": "etc/passwd"}]}' > det/list.json
probe "detect --images via a symbolic link out" "leads outside" -- detect --weights "$weights" --images det/list.json --out det/dt.json

echo "## panics and ranges"
mkdir pfm && printf 'Pf\n4294967296 4294967296\n-1.0\n' > pfm/huge.pfm
convert_png() { python3 -c "import zlib,struct,sys
w,h=8,8; raw=b''.join(b'\x00'+b'\x80'*3*w for _ in range(h))
def c(t,d): return struct.pack('>I',len(d))+t+d+struct.pack('>I',zlib.crc32(t+d)&0xffffffff)
open(sys.argv[1],'wb').write(b'\x89PNG\r\n\x1a\n'+c(b'IHDR',struct.pack('>IIBBBBB',w,h,8,2,0,0,0))+c(b'IDAT',zlib.compress(raw))+c(b'IEND',b''))" "$1"; }
convert_png pfm/a.png; convert_png pfm/b.png
probe "flow --gt-disparity (PFM w*h overflows)" "from 1 to 32768" -- flow pfm/a.png pfm/b.png --out pfm/f.png --gt-disparity pfm/huge.pfm
[[ ! -e pfm/f.png ]] && echo "  no flow PNG written before the failed check: ok" || { echo "  f.png written: FAIL"; fails=$((fails+1)); }
probe "detect --width 100000" "4..=128" -- detect --weights "$weights" --images det/list.json --out det/dt.json --width 100000
probe "detect --threads 100000" "1..=64" -- detect --weights "$weights" --images det/list.json --out det/dt.json --threads 100000
probe "bench detector --threads 100000" "from 1 to 64" -- bench detector --threads 100000
probe "experiment --jobs 0" "from 1 to 64" -- experiment exp.toml --jobs 0
probe "form --noise-scale inf" "allowed 0 to 1000" -- form --input pfm/a.png --exposure-ms 5 --gain-db 10 --sensor IMX172 --noise-scale inf --out pfm/o.png
probe "render --blur-scale 1e300" "allowed 0 to 100" -- render --blur-scale 1e300 --out r
probe "blur --exposure-ms inf" "allowed above 0 to 1000" -- blur pfm --exposure-ms inf --out bl

echo "## silent nonsense: folder sources"
mkdir -p rec/frames && convert_png rec/frames/0.png && convert_png rec/frames/1.png
mk() { printf '{"images": [{"id": 1, "file_name": "frames/0.png", "width": 8, "height": 8, "timestamp_s": 0, "exposure_s": 0.005%s}, {"id": %s, "file_name": "%s", "width": 8, "height": 8, "timestamp_s": 0.1, "exposure_s": 0.005}], "annotations": [], "categories": [{"id": 1, "name": "car"}]}' "$1" "$2" "$3" > rec/annotations.json; }
for case in ', "gain_db": 1e300|2|frames/1.png|gain_db' ', "exposure_s": 1e300|2|frames/1.png|exposure_s' '|1|frames/1.png|declared twice' '|2|frames/0.png|already another image'; do
  IFS='|' read -r extra id file expect <<<"$case"
  mk "$extra" "$id" "$file"
  probe "run --source folder: $expect" "$expect" -- run --config long.toml --source folder:rec --out "rr-$id-$RANDOM"
done

echo "## eval and report"
printf '[run]\nthreads = 1\ngenerations = 1\npopulation = 2\nsteps_per_candidate = 3\ntest_episodes = 1\ntest_frames_per_episode = 2\n' > tiny.toml
"$joca" run --config tiny.toml --out done >/dev/null 2>&1
sum="$(sha256sum done/results.json)"
probe "eval RUN" "" -- eval done
[[ "$(sha256sum done/results.json)" == "$sum" && -f done/results-eval.json ]] && echo "  run's results.json kept, results-eval.json written: ok" || { echo "  eval: FAIL"; fails=$((fails+1)); }
printf '{"step": \xff}\n' >> done/events.jsonl
probe "report RUN with a bad events.jsonl line" "could not be read and are left out" -- report done
echo "probes failed: $fails"
