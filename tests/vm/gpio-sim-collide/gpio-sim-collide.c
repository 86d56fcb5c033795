// SPDX-License-Identifier: GPL-2.0
/*
 * gpio-sim-collide: a virtual GPIO chip for Collide's VM tests.
 *
 * Debian's 6.1 kernel ships neither gpio-sim nor gpio-mockup, so the tests
 * bring this small chip: it registers a gpio_chip with `nlines` lines (names
 * from `line_names`), behaves like gpio-sim (a released line turns back into
 * an input at its pull level, from `pull_up_mask`), and logs every change a
 * line goes through with its CLOCK_MONOTONIC kernel timestamp (ktime_get_ns,
 * the clock user space reads with clock_gettime(CLOCK_MONOTONIC)).
 *
 * /proc/gpio-sim-collide/events   one line per change, oldest first:
 *                                 "<ns> <offset> <kind> <value>"
 *                                 kind: o = driven as output to value,
 *                                       i = made an input (value = pull level),
 *                                       f = released by its user (value = pull level)
 *                                 write anything to clear the log
 * /proc/gpio-sim-collide/levels   the level (0/1) of every line, one per row,
 *                                 "<offset> <name> <level> <in|out>"
 * /proc/gpio-sim-collide/unplug   write anything: the chip goes away for good
 *                                 (gpiochip_remove, as when a USB GPIO adapter
 *                                 is pulled), even with lines held; their
 *                                 users then get ENODEV
 */
#include <linux/gpio/driver.h>
#include <linux/ktime.h>
#include <linux/mutex.h>
#include <linux/module.h>
#include <linux/platform_device.h>
#include <linux/proc_fs.h>
#include <linux/seq_file.h>
#include <linux/slab.h>
#include <linux/spinlock.h>

#define GSC_NAME "gpio-sim-collide"
#define GSC_MAX_LINES 64
#define GSC_LOG_SIZE 8192

static unsigned int nlines = 8;
module_param(nlines, uint, 0444);
MODULE_PARM_DESC(nlines, "number of lines (1..64)");

static char *line_names[GSC_MAX_LINES];
static int n_line_names;
module_param_array(line_names, charp, &n_line_names, 0444);
MODULE_PARM_DESC(line_names, "comma-separated line names, line 0 first");

static unsigned long long pull_up_mask;
module_param(pull_up_mask, ullong, 0444);
MODULE_PARM_DESC(pull_up_mask, "bit N set: line N is pulled high when nobody drives it");

struct gsc_event {
	u64 ns;
	u16 offset;
	char kind;
	u8 value;
};

struct gsc_chip {
	struct gpio_chip gc;
	spinlock_t lock;
	unsigned long long level;     /* bit per line */
	unsigned long long is_output; /* bit per line */
	struct gsc_event log[GSC_LOG_SIZE];
	unsigned int log_len;
	unsigned int log_dropped;
	const char *names[GSC_MAX_LINES];
	char default_names[GSC_MAX_LINES][16];
};

static struct gsc_chip *gsc;
static struct platform_device *gsc_pdev;
static struct proc_dir_entry *gsc_proc;

/* Called with the lock held. */
static void gsc_log(struct gsc_chip *c, unsigned int offset, char kind, int value)
{
	if (c->log_len >= GSC_LOG_SIZE) {
		c->log_dropped++;
		return;
	}
	c->log[c->log_len].ns = ktime_get_ns();
	c->log[c->log_len].offset = offset;
	c->log[c->log_len].kind = kind;
	c->log[c->log_len].value = value ? 1 : 0;
	c->log_len++;
}

static void gsc_assign(struct gsc_chip *c, unsigned int offset, int value)
{
	if (value)
		c->level |= 1ULL << offset;
	else
		c->level &= ~(1ULL << offset);
}

static int gsc_pull(unsigned int offset)
{
	return (pull_up_mask >> offset) & 1;
}

static int gsc_get_direction(struct gpio_chip *gc, unsigned int offset)
{
	struct gsc_chip *c = gpiochip_get_data(gc);

	return (c->is_output >> offset) & 1 ? GPIO_LINE_DIRECTION_OUT : GPIO_LINE_DIRECTION_IN;
}

static int gsc_direction_input(struct gpio_chip *gc, unsigned int offset)
{
	struct gsc_chip *c = gpiochip_get_data(gc);
	unsigned long flags;

	spin_lock_irqsave(&c->lock, flags);
	c->is_output &= ~(1ULL << offset);
	gsc_assign(c, offset, gsc_pull(offset));
	gsc_log(c, offset, 'i', gsc_pull(offset));
	spin_unlock_irqrestore(&c->lock, flags);
	return 0;
}

static int gsc_direction_output(struct gpio_chip *gc, unsigned int offset, int value)
{
	struct gsc_chip *c = gpiochip_get_data(gc);
	unsigned long flags;

	spin_lock_irqsave(&c->lock, flags);
	c->is_output |= 1ULL << offset;
	gsc_assign(c, offset, value);
	gsc_log(c, offset, 'o', value);
	spin_unlock_irqrestore(&c->lock, flags);
	return 0;
}

static int gsc_get(struct gpio_chip *gc, unsigned int offset)
{
	struct gsc_chip *c = gpiochip_get_data(gc);

	return (c->level >> offset) & 1;
}

static void gsc_set(struct gpio_chip *gc, unsigned int offset, int value)
{
	struct gsc_chip *c = gpiochip_get_data(gc);
	unsigned long flags;

	spin_lock_irqsave(&c->lock, flags);
	gsc_assign(c, offset, value);
	gsc_log(c, offset, 'o', value);
	spin_unlock_irqrestore(&c->lock, flags);
}

/* Like gpio-sim: a released line goes back to an input at its pull level. */
static void gsc_free(struct gpio_chip *gc, unsigned int offset)
{
	struct gsc_chip *c = gpiochip_get_data(gc);
	unsigned long flags;

	spin_lock_irqsave(&c->lock, flags);
	c->is_output &= ~(1ULL << offset);
	gsc_assign(c, offset, gsc_pull(offset));
	gsc_log(c, offset, 'f', gsc_pull(offset));
	spin_unlock_irqrestore(&c->lock, flags);
}

static int gsc_events_show(struct seq_file *m, void *v)
{
	unsigned int i, n, dropped;
	struct gsc_event *copy;
	unsigned long flags;

	copy = kvmalloc_array(GSC_LOG_SIZE, sizeof(*copy), GFP_KERNEL);
	if (!copy)
		return -ENOMEM;
	spin_lock_irqsave(&gsc->lock, flags);
	n = gsc->log_len;
	dropped = gsc->log_dropped;
	memcpy(copy, gsc->log, n * sizeof(*copy));
	spin_unlock_irqrestore(&gsc->lock, flags);
	for (i = 0; i < n; i++)
		seq_printf(m, "%llu %u %c %u\n", copy[i].ns, copy[i].offset, copy[i].kind,
			   copy[i].value);
	if (dropped)
		seq_printf(m, "# dropped %u events (log full)\n", dropped);
	kvfree(copy);
	return 0;
}

static int gsc_events_open(struct inode *inode, struct file *file)
{
	return single_open_size(file, gsc_events_show, NULL, GSC_LOG_SIZE * 40 + 64);
}

static ssize_t gsc_events_write(struct file *file, const char __user *buf, size_t len,
				loff_t *off)
{
	unsigned long flags;

	spin_lock_irqsave(&gsc->lock, flags);
	gsc->log_len = 0;
	gsc->log_dropped = 0;
	spin_unlock_irqrestore(&gsc->lock, flags);
	return len;
}

static DEFINE_MUTEX(gsc_unplug_lock);
static bool gsc_unplugged;

static void gsc_remove_chip(void)
{
	mutex_lock(&gsc_unplug_lock);
	if (!gsc_unplugged) {
		gpiochip_remove(&gsc->gc);
		gsc_unplugged = true;
	}
	mutex_unlock(&gsc_unplug_lock);
}

static ssize_t gsc_unplug_write(struct file *file, const char __user *buf, size_t len,
				loff_t *off)
{
	gsc_remove_chip();
	return len;
}

static const struct proc_ops gsc_unplug_ops = {
	.proc_write = gsc_unplug_write,
};

static const struct proc_ops gsc_events_ops = {
	.proc_open = gsc_events_open,
	.proc_read = seq_read,
	.proc_lseek = seq_lseek,
	.proc_release = single_release,
	.proc_write = gsc_events_write,
};

static int gsc_levels_show(struct seq_file *m, void *v)
{
	unsigned int i;

	for (i = 0; i < gsc->gc.ngpio; i++)
		seq_printf(m, "%u %s %llu %s\n", i, gsc->names[i], (gsc->level >> i) & 1,
			   (gsc->is_output >> i) & 1 ? "out" : "in");
	return 0;
}

static int __init gsc_init(void)
{
	unsigned int i;
	int ret;

	if (nlines < 1 || nlines > GSC_MAX_LINES)
		return -EINVAL;
	gsc = kvzalloc(sizeof(*gsc), GFP_KERNEL);
	if (!gsc)
		return -ENOMEM;
	spin_lock_init(&gsc->lock);
	for (i = 0; i < nlines; i++) {
		if (i < n_line_names && line_names[i] && line_names[i][0]) {
			gsc->names[i] = line_names[i];
		} else {
			snprintf(gsc->default_names[i], sizeof(gsc->default_names[i]), "collide-%u", i);
			gsc->names[i] = gsc->default_names[i];
		}
		gsc_assign(gsc, i, gsc_pull(i));
	}

	gsc_pdev = platform_device_register_simple(GSC_NAME, PLATFORM_DEVID_NONE, NULL, 0);
	if (IS_ERR(gsc_pdev)) {
		ret = PTR_ERR(gsc_pdev);
		goto err_free;
	}

	gsc->gc.label = GSC_NAME;
	gsc->gc.parent = &gsc_pdev->dev;
	gsc->gc.owner = THIS_MODULE;
	gsc->gc.base = -1;
	gsc->gc.ngpio = nlines;
	gsc->gc.names = gsc->names;
	gsc->gc.can_sleep = false;
	gsc->gc.get_direction = gsc_get_direction;
	gsc->gc.direction_input = gsc_direction_input;
	gsc->gc.direction_output = gsc_direction_output;
	gsc->gc.get = gsc_get;
	gsc->gc.set = gsc_set;
	gsc->gc.free = gsc_free;
	ret = gpiochip_add_data(&gsc->gc, gsc);
	if (ret)
		goto err_pdev;

	gsc_proc = proc_mkdir(GSC_NAME, NULL);
	if (!gsc_proc) {
		ret = -ENOMEM;
		goto err_chip;
	}
	proc_create("events", 0666, gsc_proc, &gsc_events_ops);
	proc_create_single("levels", 0444, gsc_proc, gsc_levels_show);
	proc_create("unplug", 0222, gsc_proc, &gsc_unplug_ops);
	pr_info(GSC_NAME ": %u lines, pull-up mask 0x%llx\n", nlines, pull_up_mask);
	return 0;

err_chip:
	gpiochip_remove(&gsc->gc);
err_pdev:
	platform_device_unregister(gsc_pdev);
err_free:
	kvfree(gsc);
	return ret;
}

static void __exit gsc_exit(void)
{
	proc_remove(gsc_proc);
	gsc_remove_chip();
	platform_device_unregister(gsc_pdev);
	kvfree(gsc);
}

module_init(gsc_init);
module_exit(gsc_exit);
MODULE_DESCRIPTION("Virtual GPIO chip that logs line changes with kernel timestamps (Collide VM tests)");
MODULE_LICENSE("GPL");
