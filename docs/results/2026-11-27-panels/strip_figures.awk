# Leaves a `joca report` markdown's figures (an image line and its italic caption) out of a
# landed report, whose figures are not committed, and says so at the end; drops a section
# heading left with nothing under it and squeezes the blank lines they leave.
# Usage: awk -v src=RUN_DIR -f strip_figures.awk report.md
/^!\[.*\]\(figures\// { skip = 1; n++; next }
skip && /^\*/ { skip = 0; next }
# A section heading waits for its first line: a heading or the end comes first when every line
# of its section was a figure.
/^## / { held = $0; skip = 0; next }
/^$/ { if (held == "" && !blank) { print; blank = 1 }; next }
{
  if (held != "") { if (!blank) print ""; print held; print ""; held = "" }
  skip = 0; blank = 0; print
}
END {
  if (!n) exit
  if (!blank) print ""
  printf "(%d figures not committed: `joca report %s` draws them on the machine that ran the cells.)\n", n, src
}
