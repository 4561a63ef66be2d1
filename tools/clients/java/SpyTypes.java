// Checks that lcm-spy would decode our types: runs lcm-spy's own type scanner (lcm.spy.LCMTypeDatabase,
// which walks java.class.path with lcm.util.ClassDiscoverer and indexes every class by its static
// LCM_FINGERPRINT), then looks up every class of the motionlcm jar by its fingerprint.
//   java -cp lcm.jar:motionlcm.jar:classes SpyTypes path/to/motionlcm.jar
import java.util.ArrayList;
import java.util.Enumeration;
import java.util.List;
import java.util.jar.JarEntry;
import java.util.jar.JarFile;

import lcm.spy.LCMTypeDatabase;

public class SpyTypes {
    public static void main(String[] args) throws Exception {
        List<String> names = new ArrayList<>();
        try (JarFile jar = new JarFile(args[0])) {
            for (Enumeration<JarEntry> e = jar.entries(); e.hasMoreElements();) {
                String n = e.nextElement().getName();
                if (n.startsWith("motionlcm/") && n.endsWith(".class") && !n.contains("$")) {
                    names.add(n.substring(0, n.length() - 6).replace('/', '.'));
                }
            }
        }
        LCMTypeDatabase db = new LCMTypeDatabase();
        int failures = 0;
        for (String name : names) {
            try {
                Class<?> cls = Class.forName(name);
                long fingerprint = cls.getField("LCM_FINGERPRINT").getLong(null);
                Class<?> found = db.getClassByFingerprint(fingerprint);
                if (found == null || !found.getName().equals(name)) {
                    System.out.printf("FAIL %s: lcm-spy's type database has %s for fingerprint %016x%n", name, found, fingerprint);
                    failures++;
                } else {
                    System.out.printf("ok %s %016x%n", name, fingerprint);
                }
            } catch (ReflectiveOperationException e) {
                System.out.println("FAIL " + name + ": " + e);
                failures++;
            }
        }
        if (names.isEmpty()) {
            System.out.println("FAIL no motionlcm classes in " + args[0]);
            failures++;
        }
        System.out.println(failures == 0 ? "lcm-spy finds all " + names.size() + " types" : failures + " types not found");
        System.exit(failures == 0 ? 0 : 1);
    }
}
