/*
 * sail_stream: the `sail estimate` stream format on a host, with libsail.
 *
 *   sail_stream < readings.csv > estimates.csv
 *
 * Input: a header line naming the columns (theta1_deg, theta2_deg, load1 and
 * load2 are needed; any others pass through), then one reading per line.
 * Output: each input line followed by fx_N, fy_N, force_N, angle_deg and
 * status, flushed per line, as `sail estimate -` writes it: every line is a
 * row (a blank one too), and a row with too few fields gets empty ones
 * appended so that its columns stay in place.  A field that is missing or
 * not a number makes the row invalid.  The calibration is the one
 * compiled in (sail_calibration.h, from `sail export-c`).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sail.h"
#include "sail_calibration.h"

#define MAX_LINE 4096
#define MAX_FIELDS 64

static const char *const STATUS_NAMES[] = {"ok", "singular", "saturated", "extrapolated", "invalid"};
static const char *const NEEDED[4] = {"theta1_deg", "theta2_deg", "load1", "load2"};
static const double PI = 3.14159265358979323846;

/* Split line at commas in place (no quoting: the stream format is numeric); returns the field count. */
static int split(char *line, char **fields)
{
    int n = 0;
    char *p = line;
    line[strcspn(line, "\r\n")] = '\0';
    fields[n++] = p;
    while ((p = strchr(p, ',')) != NULL && n < MAX_FIELDS) {
        *p++ = '\0';
        fields[n++] = p;
    }
    return n;
}

static double number(const char *text)
{
    char *end;
    double x;
    while (*text == ' ')
        text++;
    x = strtod(text, &end);
    while (*end == ' ')
        end++;
    return (end == text || *end != '\0') ? NAN : x;
}

static void print_number(double x)
{
    if (isnan(x))
        putchar(',');
    else
        printf(",%.9g", x);
}

int main(void)
{
    char line[MAX_LINE], copy[MAX_LINE], *fields[MAX_FIELDS];
    int index[4], n_columns, i, j;
    unsigned long counts[5] = {0, 0, 0, 0, 0};
    if (!fgets(line, sizeof line, stdin)) {
        fprintf(stderr, "sail_stream: the stream ended before its header line\n");
        return 1;
    }
    strcpy(copy, line);
    n_columns = split(copy, fields);
    for (i = 0; i < 4; i++) {
        index[i] = -1;
        for (j = 0; j < n_columns; j++)
            if (!strcmp(fields[j], NEEDED[i]))
                index[i] = j;
        if (index[i] < 0) {
            fprintf(stderr, "sail_stream: the header lacks column %s\n", NEEDED[i]);
            return 1;
        }
    }
    line[strcspn(line, "\r\n")] = '\0';
    printf("%s,fx_N,fy_N,force_N,angle_deg,status\n", line);
    fflush(stdout);
    while (fgets(line, sizeof line, stdin)) {
        double v[4];
        sail_reading r;
        sail_force f;
        int n;
        line[strcspn(line, "\r\n")] = '\0';
        strcpy(copy, line);
        n = split(copy, fields);
        for (i = 0; i < 4; i++)
            v[i] = (n == n_columns) ? number(fields[index[i]]) : NAN;
        r.theta1 = (sail_real)(v[0] * PI / 180);
        r.theta2 = (sail_real)(v[1] * PI / 180);
        r.load1 = (sail_real)v[2];
        r.load2 = (sail_real)v[3];
        sail_estimate(&sail_cal, &r, &f);
        counts[f.status]++;
        fputs(line, stdout);
        for (i = n; i < n_columns; i++)
            putchar(',');
        print_number(f.fx);
        print_number(f.fy);
        print_number(hypot(f.fx, f.fy));
        print_number(atan2(f.fy, f.fx) * 180 / PI);
        printf(",%s\n", STATUS_NAMES[f.status]);
        fflush(stdout);
    }
    fprintf(stderr, "ok %lu, singular %lu, saturated %lu, extrapolated %lu, invalid %lu\n",
            counts[0], counts[1], counts[2], counts[3], counts[4]);
    return 0;
}
