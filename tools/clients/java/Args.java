// Tiny command-line parser shared by the Java examples: "--name value", "--name=value", and options
// taking several values ("--axes x y"). Unknown options are an error (exit code 2).
import java.util.ArrayList;
import java.util.HashMap;
import java.util.List;
import java.util.Map;

final class Args {
    private final Map<String, List<String>> values = new HashMap<>();

    Args(String[] argv, Map<String, Integer> arity, String usage) {
        for (int i = 0; i < argv.length; i++) {
            String a = argv[i];
            if (a.equals("--help") || a.equals("-h")) {
                System.out.println(usage);
                System.exit(0);
            }
            String name = a;
            List<String> vals = new ArrayList<>();
            int eq = a.indexOf('=');
            if (a.startsWith("--") && eq > 0) {
                name = a.substring(0, eq);
                vals.add(a.substring(eq + 1));
            }
            Integer n = arity.get(name);
            if (n == null) fail("unknown option " + a, usage);
            while (vals.size() < n) {
                if (++i >= argv.length) fail(name + " needs " + n + " value(s)", usage);
                vals.add(argv[i]);
            }
            values.put(name, vals);
        }
    }

    static void fail(String message, String usage) {
        System.err.println(message + "\n" + usage);
        System.exit(2);
    }

    String get(String name, String fallback) {
        List<String> v = values.get(name);
        return v == null ? fallback : v.get(0);
    }

    List<String> list(String name, List<String> fallback) {
        List<String> v = values.get(name);
        return v == null ? fallback : v;
    }
}
