# Shared by tools/spy and tools/logplayer: runs one of LCM's Java tools (lcm.jar) directly with
# java. Debian's launchers (lcm-spy, lcm-logplayer-gui) pass -Xincgc, which Java 17 refuses.
# Overrides: JAVA, LCM_JAR (default /usr/share/java/lcm.jar).
#   lcm_java_run TOOL CLASS CLASSPATH_EXTRA ARGS...   (exec; exit 1 naming what is missing)
lcm_java_run() {
  local tool=$1 class=$2 extra_cp=$3
  shift 3
  local lcm_jar=${LCM_JAR:-/usr/share/java/lcm.jar}
  local java=${JAVA:-$(command -v java || true)}
  [ -n "$java" ] || { echo "$tool: java not found (apt-get install default-jre)" >&2; exit 1; }
  [ -f "$lcm_jar" ] || { echo "$tool: $lcm_jar not found (apt-get install liblcm-java)" >&2; exit 1; }
  exec "$java" -server -Djava.net.preferIPv4Stack=true -Xmx128m -Xms64m -ea -cp "$lcm_jar${extra_cp:+:$extra_cp}" "$class" "$@"
}
