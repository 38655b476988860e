# Sourced by the benchmark scripts: split() cuts a CSV record with a header row in two.
# split FILE N NAME: data rows 0..N−1 (with the header) into $work/NAME-est.csv, the rest into
# $work/NAME-val.csv ($work: the caller's scratch folder).
split() {
  local file=$1 rows=$2 name=$3
  head -n $((rows + 1)) "$file" > "$work/$name-est.csv"
  { head -n 1 "$file"; tail -n +$((rows + 2)) "$file"; } > "$work/$name-val.csv"
}
